// MAML's inner adaptation (Finn et al. 2017, "Model-Agnostic Meta-Learning for Fast Adaptation
// of Deep Networks") for a FunctionalGaussian: gradient steps on the vanilla policy-gradient
// loss of one task's rollouts, differentiable with respect to the pre-adaptation parameters
// when `create_graph` is true (the outer loss then sees the second-order term).
#pragma once

#include <vector>

#include <torch/torch.h>

#include "metarl/functional_policy.h"
#include "rl/ppo.h"

namespace bidex::metarl {

// PPO's clipped surrogate, the outer objective of MAML-PPO and ProMP: rl::clipped_surrogate
// returns -mean(min(r A, clamp(r, 1 - clip, 1 + clip) A)), the loss to minimise.
using rl::clipped_surrogate;

// The REINFORCE loss -mean(log pi(a|s) A) over rows: obs [B, D], actions [B, A],
// advantages [B] (treated as constants: they are detached).
torch::Tensor pg_loss(const FunctionalGaussian& pi, const std::vector<torch::Tensor>& params,
                      const torch::Tensor& obs, const torch::Tensor& actions,
                      const torch::Tensor& advantages);

// The inner step's size: one number for every parameter, or (Meta-SGD, Li et al. 2017, "Meta-SGD:
// Learning to Learn Quickly for Few-Shot Learning") one tensor per parameter of that parameter's
// shape, multiplied element by element with its gradient; the outer loss learns those when they
// require grad (GradientMetaConfig::learn_inner_lr). A number converts implicitly.
struct StepSize {
  StepSize(double lr = 0) : lr(lr) {}  // NOLINT(google-explicit-constructor): a plain size
  StepSize(double lr, std::vector<torch::Tensor> per_param)
      : lr(lr), per_param(std::move(per_param)) {}
  double lr;                             // used where per_param is empty
  std::vector<torch::Tensor> per_param;  // one per parameter, or none
};

// `params` where they require grad, detached copies that do where they do not: autograd::grad
// differentiates only tensors in the graph, and a list adapted at evaluation is often detached.
std::vector<torch::Tensor> differentiable(const std::vector<torch::Tensor>& params);

// params - lr * grad(loss), tensor by tensor (with per-parameter sizes, element by element),
// for a `loss` built from `params` (which must all require grad). With create_graph the
// gradient is part of the graph (second order); without it the gradient is a constant, so the
// result depends on `params` only through the identity (first-order MAML), and on learned
// step sizes through the product either way.
std::vector<torch::Tensor> gradient_step(const torch::Tensor& loss,
                                         const std::vector<torch::Tensor>& params,
                                         const StepSize& lr, bool create_graph);

// One inner step: params - inner_lr * grad pg_loss(params). Parameters that do not require
// grad are adapted from detached copies that do.
std::vector<torch::Tensor> inner_step(const FunctionalGaussian& pi,
                                      const std::vector<torch::Tensor>& params,
                                      const torch::Tensor& obs, const torch::Tensor& actions,
                                      const torch::Tensor& advantages, const StepSize& inner_lr,
                                      bool create_graph);

// `steps` inner steps on the same rows (steps = 0 returns `params`).
std::vector<torch::Tensor> inner_steps(const FunctionalGaussian& pi,
                                       const std::vector<torch::Tensor>& params,
                                       const torch::Tensor& obs, const torch::Tensor& actions,
                                       const torch::Tensor& advantages, const StepSize& inner_lr,
                                       int steps, bool create_graph);

}  // namespace bidex::metarl
