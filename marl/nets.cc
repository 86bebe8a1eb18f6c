#include "marl/nets.h"

#include <cmath>

namespace bidex::marl {

torch::nn::Linear head(int64_t in, int64_t out, double gain) {
  torch::nn::Linear lin(in, out);
  torch::nn::init::orthogonal_(lin->weight, gain);
  torch::nn::init::zeros_(lin->bias);
  return lin;
}

torch::nn::Sequential mlp_body(int64_t in, const NetConfig& net) {
  torch::nn::Sequential s;
  if (net.feature_norm) s->push_back(torch::nn::LayerNorm(torch::nn::LayerNormOptions({in})));
  int64_t width = in;
  for (int h : net.hidden) {
    s->push_back(head(width, h, std::sqrt(2.0)));
    if (net.activation == "elu") s->push_back(torch::nn::ELU());
    else if (net.activation == "relu") s->push_back(torch::nn::ReLU());
    else s->push_back(torch::nn::Tanh());
    if (net.layer_norm) s->push_back(torch::nn::LayerNorm(torch::nn::LayerNormOptions({h})));
    width = h;
  }
  if (s->size() == 0) s->push_back(torch::nn::Identity());
  return s;
}

int64_t body_width(int64_t in, const NetConfig& net) {
  return net.hidden.empty() ? in : net.hidden.back();
}

GaussianActorImpl::GaussianActorImpl(int64_t obs_dim, int64_t act_dim, const OnPolicyConfig& c)
    : x_(c.std_x_coef), y_(c.std_y_coef) {
  body_ = register_module("body", mlp_body(obs_dim, c.net));
  out_ = register_module("mean", head(body_width(obs_dim, c.net), act_dim, 0.01));
  log_std_ = register_parameter("log_std", torch::full({act_dim}, c.log_std_init));
}

torch::Tensor GaussianActorImpl::mean(const torch::Tensor& obs) {
  return out_(body_->forward(obs));
}

torch::Tensor GaussianActorImpl::std() const { return torch::sigmoid(log_std_ / x_) * y_; }

torch::Tensor GaussianActorImpl::log_prob(const torch::Tensor& obs, const torch::Tensor& a) {
  return rl::gaussian_log_prob(a, mean(obs), log_std());
}

torch::Tensor GaussianActorImpl::entropy() const { return rl::gaussian_entropy(log_std()); }

ValueNetImpl::ValueNetImpl(int64_t in, const NetConfig& net) {
  body_ = register_module("body", mlp_body(in, net));
  out_ = register_module("value", head(body_width(in, net), 1, 1.0));
}

torch::Tensor ValueNetImpl::forward(const torch::Tensor& x) {
  return out_(body_->forward(x)).squeeze(-1);
}

TanhActorImpl::TanhActorImpl(int64_t obs_dim, int64_t act_dim, const NetConfig& net) {
  body_ = register_module("body", mlp_body(obs_dim, net));
  out_ = register_module("action", head(body_width(obs_dim, net), act_dim, 0.01));
}

torch::Tensor TanhActorImpl::preact(const torch::Tensor& obs) { return out_(body_->forward(obs)); }

torch::Tensor value_error(const torch::Tensor& err, double delta) {
  if (delta <= 0) return 0.5 * err.pow(2);
  const auto a = err.abs();
  return torch::where(a <= delta, 0.5 * err.pow(2), delta * (a - 0.5 * delta));
}

}  // namespace bidex::marl
