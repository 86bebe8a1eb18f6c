#include "offline/nets.h"

#include "rl/policy.h"

namespace bidex::offline {

namespace {

torch::nn::Linear linear(int64_t in, int64_t out, double orthogonal_gain) {
  torch::nn::Linear l(in, out);
  if (orthogonal_gain > 0) torch::nn::init::orthogonal_(l->weight, orthogonal_gain);
  return l;
}

}  // namespace

torch::nn::Sequential relu_trunk(int64_t in, const std::vector<int>& hidden,
                                 double orthogonal_gain) {
  torch::nn::Sequential net;
  for (int h : hidden) {
    net->push_back(linear(in, h, orthogonal_gain));
    net->push_back(torch::nn::ReLU());
    in = h;
  }
  return net;
}

torch::nn::Sequential relu_mlp(int64_t in, const std::vector<int>& hidden, int64_t out,
                               double orthogonal_gain) {
  auto net = relu_trunk(in, hidden, orthogonal_gain);
  net->push_back(linear(hidden.empty() ? in : hidden.back(), out, orthogonal_gain));
  return net;
}

rl::QCritic twin_q(int64_t obs_dim, int64_t act_dim, const std::vector<int>& hidden,
                   double orthogonal_gain) {
  return rl::QCritic(relu_mlp(obs_dim + act_dim, hidden, 1, orthogonal_gain),
                     relu_mlp(obs_dim + act_dim, hidden, 1, orthogonal_gain));
}

ObsNormImpl::ObsNormImpl(int64_t dim) {
  mean = register_buffer("mean", torch::zeros({dim}));
  sd = register_buffer("std", torch::ones({dim}));
}

}  // namespace bidex::offline
