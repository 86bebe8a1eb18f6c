// A Gaussian MLP policy whose parameters are passed in, not owned: meta-RL adapts a policy by
// gradient steps and then differentiates through them, so the adapted policy must be the same
// function of a different parameter list (MAML, ProMP). Pulls in LibTorch.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <torch/torch.h>

namespace bidex::metarl {

// The mean is an MLP (the architecture of rl::mlp: `hidden` layers of `activation`, then a
// linear output); the log-std is state-independent. A parameter list holds, in order,
//   W0 [hidden[0], obs_dim], b0 [hidden[0]], ..., Wout [act_dim, last width], bout [act_dim],
//   log_std [act_dim]
// (the order of rl::ActorCritic::actor_parameters). Actions are the Gaussian's unsquashed
// samples; clamping to [-1, 1] happens outside, as in PPO.
struct FunctionalGaussian {
  int64_t obs_dim = 0, act_dim = 0;
  std::vector<int> hidden;
  std::string activation = "tanh";  // elu, relu or tanh (rl::mlp's)
  // The meta-parameters: leaves that require grad, float32, on the CPU (move them with to()).
  std::vector<torch::Tensor> params;

  // Orthogonal weights as rl::mlp draws them (gain sqrt 2 for hidden layers, 0.01 for the mean's
  // output layer, as rl::ActorCritic), zero biases, log_std = log(init_std). Drawn from a
  // generator seeded with `seed`; the global CPU generator's state is restored afterwards.
  // Throws std::invalid_argument on non-positive dimensions, init_std or an unknown activation.
  static FunctionalGaussian init(int64_t obs_dim, const std::vector<int>& hidden, int64_t act_dim,
                                 const std::string& activation, double init_std, uint64_t seed);

  // Throws std::invalid_argument unless `p` has this architecture's count and shapes.
  void check(const std::vector<torch::Tensor>& p) const;
  // `params` converted to `options` (dtype, device), as new leaves that require grad.
  void to(const torch::TensorOptions& options);

  // For obs [B, obs_dim]: the mean [B, act_dim].
  torch::Tensor mean(const std::vector<torch::Tensor>& p, const torch::Tensor& obs) const;
  torch::Tensor log_std(const std::vector<torch::Tensor>& p) const { return p.back(); }
  // log pi(actions | obs) [B], summed over the action dimensions; actions [B, act_dim].
  torch::Tensor log_prob(const std::vector<torch::Tensor>& p, const torch::Tensor& obs,
                         const torch::Tensor& actions) const;
  // Mean over the rows of KL(pi_old(.|obs) || pi_new(.|obs)), a scalar. Gradients flow into
  // both lists; detach `p_old` for a penalty towards a fixed policy.
  torch::Tensor kl(const std::vector<torch::Tensor>& p_old, const std::vector<torch::Tensor>& p_new,
                   const torch::Tensor& obs) const;
  // The entropy of the Gaussian (the same in every state, the log-std being state-independent).
  torch::Tensor entropy(const std::vector<torch::Tensor>& p) const;
};

// Copies of `p` cut from the graph that require grad: the starting point of an adaptation that
// the outer loss should not differentiate through (evaluation on a new task).
std::vector<torch::Tensor> detached(const std::vector<torch::Tensor>& p);

}  // namespace bidex::metarl
