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

TwinQImpl::TwinQImpl(int64_t obs_dim, int64_t act_dim, const std::vector<int>& hidden,
                     double orthogonal_gain) {
  q1 = register_module("q1", relu_mlp(obs_dim + act_dim, hidden, 1, orthogonal_gain));
  q2 = register_module("q2", relu_mlp(obs_dim + act_dim, hidden, 1, orthogonal_gain));
}

std::pair<torch::Tensor, torch::Tensor> TwinQImpl::forward(const torch::Tensor& obs,
                                                           const torch::Tensor& act) {
  const auto x = torch::cat({obs, act}, 1);
  return {q1->forward(x).squeeze(1), q2->forward(x).squeeze(1)};
}

torch::Tensor TwinQImpl::first(const torch::Tensor& obs, const torch::Tensor& act) {
  return q1->forward(torch::cat({obs, act}, 1)).squeeze(1);
}

ObsNormImpl::ObsNormImpl(int64_t dim) {
  mean = register_buffer("mean", torch::zeros({dim}));
  sd = register_buffer("std", torch::ones({dim}));
}

void make_target(torch::nn::Module& net, torch::nn::Module& target) {
  rl::polyak_update(net, target, 0.0);
  for (auto& p : target.parameters()) p.set_requires_grad(false);
}

}  // namespace bidex::offline
