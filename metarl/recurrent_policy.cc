#include "metarl/recurrent_policy.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace bidex::metarl {

torch::Tensor rl2_input(const torch::Tensor& obs, const torch::Tensor& prev_action,
                        const torch::Tensor& prev_reward, const torch::Tensor& prev_done) {
  const auto o = obs.options();
  return torch::cat({obs, prev_action.to(o), prev_reward.to(o).unsqueeze(-1),
                     prev_done.to(o).unsqueeze(-1)},
                    -1);
}

torch::Tensor symlog(const torch::Tensor& x) { return torch::sign(x) * torch::log1p(x.abs()); }

RecurrentPolicyImpl::RecurrentPolicyImpl(int64_t obs_dim, int64_t act_dim, int64_t hidden_size,
                                         double init_std, bool input_norm)
    : obs_dim_(obs_dim), act_dim_(act_dim), hidden_size_(hidden_size) {
  if (obs_dim <= 0 || act_dim <= 0 || hidden_size <= 0 || !(init_std > 0))
    throw std::invalid_argument(
        "RecurrentPolicy: obs_dim, act_dim, hidden_size and init_std must be positive, got " +
        std::to_string(obs_dim) + ", " + std::to_string(act_dim) + ", " +
        std::to_string(hidden_size) + " and " + std::to_string(init_std));
  gru_ = register_module("gru", torch::nn::GRU(torch::nn::GRUOptions(input_dim(), hidden_size)));
  mean_head_ = register_module("mean_head", torch::nn::Linear(hidden_size, act_dim));
  value_head_ = register_module("value_head", torch::nn::Linear(hidden_size, 1));
  // the heads start as rl::ActorCritic's output layers: a near-zero mean, a unit-scale value
  torch::NoGradGuard ng;
  torch::nn::init::orthogonal_(mean_head_->weight, 0.01);
  torch::nn::init::zeros_(mean_head_->bias);
  torch::nn::init::orthogonal_(value_head_->weight, 1.0);
  torch::nn::init::zeros_(value_head_->bias);
  log_std_ = register_parameter("log_std", torch::full({act_dim}, std::log(init_std)));
  if (input_norm) obs_norm_ = register_module("obs_norm", rl::RunningNorm(obs_dim));
}

torch::Tensor RecurrentPolicyImpl::input(const torch::Tensor& obs, const torch::Tensor& prev_action,
                                         const torch::Tensor& prev_reward,
                                         const torch::Tensor& prev_done) const {
  if (!input_norm()) return rl2_input(obs, prev_action, prev_reward, prev_done);
  return rl2_input(obs_norm_->normalize(obs), prev_action, symlog(prev_reward), prev_done);
}

void RecurrentPolicyImpl::update_input_norm(const torch::Tensor& obs) {
  if (input_norm()) obs_norm_->update(obs);
}

std::tuple<torch::Tensor, torch::Tensor, torch::Tensor> RecurrentPolicyImpl::forward_step(
    const torch::Tensor& input, const torch::Tensor& hidden) {
  TORCH_CHECK(input.dim() == 2 && input.size(1) == input_dim(),
              "RecurrentPolicy::forward_step: input must be [N, ", input_dim(), "], got ",
              input.sizes());
  TORCH_CHECK(hidden.dim() == 3 && hidden.size(0) == 1 && hidden.size(1) == input.size(0) &&
                  hidden.size(2) == hidden_size_,
              "RecurrentPolicy::forward_step: hidden must be [1, ", input.size(0), ", ",
              hidden_size_, "], got ", hidden.sizes());
  // a sequence of length one: the GRU's output row is its new hidden state
  auto [out, h] = gru_->forward(input.unsqueeze(0), hidden);
  auto y = out[0];
  return {mean_head_->forward(y), value_head_->forward(y).squeeze(-1), h};
}

std::tuple<torch::Tensor, torch::Tensor, torch::Tensor> RecurrentPolicyImpl::forward_sequence(
    const torch::Tensor& inputs, const torch::Tensor& hidden0, const torch::Tensor& resets) {
  TORCH_CHECK(inputs.dim() == 3 && resets.dim() == 2 && resets.size(0) == inputs.size(0) &&
                  resets.size(1) == inputs.size(1),
              "RecurrentPolicy::forward_sequence: inputs [T, N, in] and resets [T, N] expected, "
              "got ",
              inputs.sizes(), " and ", resets.sizes());
  const int64_t T = inputs.size(0);
  std::vector<torch::Tensor> means, values, hiddens;
  means.reserve(T);
  values.reserve(T);
  hiddens.reserve(T);
  auto keep = (1 - resets.to(inputs.options())).unsqueeze(-1);  // [T, N, 1]
  auto h = hidden0;
  // step by step: the reset must act between steps, which one call over the sequence cannot do
  for (int64_t t = 0; t < T; ++t) {
    h = h * keep[t];
    auto [mu, v, h_next] = forward_step(inputs[t], h);
    means.push_back(mu);
    values.push_back(v);
    hiddens.push_back(h_next[0]);
    h = h_next;
  }
  return {torch::stack(means), torch::stack(values), torch::stack(hiddens)};
}

torch::Tensor RecurrentPolicyImpl::initial_hidden(int64_t n) const {
  return torch::zeros({1, n, hidden_size_}, log_std_.options().requires_grad(false));
}

}  // namespace bidex::metarl
