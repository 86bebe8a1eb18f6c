// The networks of the multi-agent family: the original's MLP body (LayerNorm over the input,
// hidden layers each followed by LayerNorm), a Gaussian actor with the original's bounded std
// (sigmoid(log_std / x) * y), a deterministic tanh actor (MADDPG), and a value network.
#pragma once

#include <torch/torch.h>

#include "marl/config.h"
#include "rl/policy.h"

namespace bidex::marl {

// LayerNorm(in) if feature_norm, then per hidden width: Linear, activation, LayerNorm if
// layer_norm; orthogonal weights with gain sqrt 2, zero biases. Its output width is the last
// hidden width (`in` when hidden is empty).
torch::nn::Sequential mlp_body(int64_t in, const NetConfig& net);
int64_t body_width(int64_t in, const NetConfig& net);
// A Linear head with orthogonal weights of `gain` and zero bias.
torch::nn::Linear head(int64_t in, int64_t out, double gain);

// One agent's (or a shared) Gaussian policy over its observation view.
class GaussianActorImpl : public torch::nn::Module {
 public:
  GaussianActorImpl(int64_t obs_dim, int64_t act_dim, const OnPolicyConfig& c);
  torch::Tensor mean(const torch::Tensor& obs);  // [n, act_dim]
  torch::Tensor std() const;                     // [act_dim]
  torch::Tensor log_std() const { return torch::log(std()); }
  // log-density of `a` under N(mean(obs), std) summed over actions [n], and the entropy [].
  torch::Tensor log_prob(const torch::Tensor& obs, const torch::Tensor& a);
  torch::Tensor entropy() const;

 private:
  double x_, y_;
  torch::nn::Sequential body_{nullptr};
  torch::nn::Linear out_{nullptr};
  torch::Tensor log_std_;
};
TORCH_MODULE(GaussianActor);

// A scalar value of an input: V(state) [n].
class ValueNetImpl : public torch::nn::Module {
 public:
  ValueNetImpl(int64_t in, const NetConfig& net);
  torch::Tensor forward(const torch::Tensor& x);

 private:
  torch::nn::Sequential body_{nullptr};
  torch::nn::Linear out_{nullptr};
};
TORCH_MODULE(ValueNet);

// A deterministic actor: tanh(head(body(obs))) in [-1, 1] (MADDPG).
class TanhActorImpl : public torch::nn::Module {
 public:
  TanhActorImpl(int64_t obs_dim, int64_t act_dim, const NetConfig& net);
  torch::Tensor forward(const torch::Tensor& obs) { return torch::tanh(preact(obs)); }
  // the action before tanh (the actor loss may penalise it: MaddpgConfig::preact_l2)
  torch::Tensor preact(const torch::Tensor& obs);

 private:
  torch::nn::Sequential body_{nullptr};
  torch::nn::Linear out_{nullptr};
};
TORCH_MODULE(TanhActor);

// The critics' loss of an error, elementwise: Huber with `delta` (err^2 / 2 within it, linear
// beyond), or err^2 / 2 when delta is 0.
torch::Tensor value_error(const torch::Tensor& err, double delta);

}  // namespace bidex::marl
