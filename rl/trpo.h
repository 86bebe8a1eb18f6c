// TRPO (Schulman et al. 2015) on the on-policy rollout of PPO: the policy takes one natural-
// gradient step per update, its direction from conjugate gradient on the Fisher matrix (the
// Hessian of the mean KL between the rollout's policy and the new one, damped), its length from
// the KL bound, then a backtracking line search that keeps the KL bound and a real improvement
// of the surrogate; the critic learns by Adam on the returns (epochs x minibatches): FlatAdam
// (rl/flat_adam.h; the checkpoint part critic_optimizer, which loads LibTorch Adam's state of
// older checkpoints too).
#pragma once

#include <functional>
#include <memory>

#include <torch/torch.h>

#include "rl/algorithm.h"

namespace bidex::rl {

// Solves A x = b for a symmetric positive definite A given as its product with a vector:
// `iters` conjugate gradient iterations from x = 0, stopping early once the residual's squared
// norm falls below `tol`.
torch::Tensor conjugate_gradient(const std::function<torch::Tensor(const torch::Tensor&)>& Avp,
                                 const torch::Tensor& b, int iters, double tol = 1e-10);

struct LineSearch {
  bool accepted = false;
  double fraction = 0;     // of the full step taken (0 when none was accepted)
  torch::Tensor params;    // x0 + fraction * full_step, or x0
  double improvement = 0;  // loss(x0) - loss(params)
};
// TRPO's backtracking line search: tries x0 + 0.5^k full_step for k = 0 .. backtracks - 1 and
// takes the first whose kl() is within max_kl and whose loss() decreased by more than
// accept_ratio times the decrease the linear model predicts (0.5^k `expected`).
LineSearch backtracking_line_search(const std::function<double(const torch::Tensor&)>& loss,
                                    const std::function<double(const torch::Tensor&)>& kl,
                                    const torch::Tensor& x0, const torch::Tensor& full_step,
                                    double expected, double max_kl, int backtracks,
                                    double accept_ratio);

// The policy's natural-gradient step, shared by TRPO and HATRPO.
struct NaturalStepSettings {
  double max_kl = 0.01;        // the KL bound of the step
  double damping = 0.1;        // added to the Fisher matrix's diagonal
  int cg_iters = 10;           // conjugate gradient iterations
  int backtracks = 10;         // line-search trials, each halving the step
  double accept_ratio = 0.5;   // least improvement accepted, as a share of the predicted one
  double step_fraction = 1.0;  // the first trial's share of the full step
};
struct NaturalStep {
  double loss = 0;      // the surrogate before the step
  double fraction = 0;  // of the full step taken (0: none)
  double kl = 0;        // the mean KL after the step (0 when no direction was found)
};
// Moves `params` one step that lowers surrogate() (a loss) within mean_kl() <= max_kl: the
// direction by conjugate gradient on the damped Fisher matrix (the Hessian of mean_kl(), which
// must be 0 with a zero gradient at the current parameters), scaled to the KL bound, then
// backtracking_line_search. Parameters are left as they were when no trial is accepted.
NaturalStep natural_step(const std::vector<torch::Tensor>& params,
                         const std::function<torch::Tensor()>& surrogate,
                         const std::function<torch::Tensor()>& mean_kl,
                         const NaturalStepSettings& settings);

std::unique_ptr<Algorithm> make_trpo(const TrainConfig& config, int64_t obs_dim, int64_t act_dim,
                                     int64_t nslot, const torch::Device& device);

}  // namespace bidex::rl
