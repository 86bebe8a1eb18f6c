// ProMP (Rothfuss et al. 2019, "ProMP: Proximal Meta-Policy Search"): the low-variance
// curvature (LVC) inner objective, the clipped outer surrogate on the adapted policy's rollouts,
// and the adaptive KL penalty that keeps the pre-adaptation policy near the one that sampled.
#pragma once

#include <vector>

#include <torch/torch.h>

#include "metarl/functional_policy.h"
#include "metarl/maml.h"

namespace bidex::metarl {

// One task's rollouts as rows: obs [B, D], actions [B, A] (the unsquashed Gaussian samples),
// advantages [B] and logp [B], the behaviour policy's log-probability of the actions when they
// were sampled (undefined where a function does not need it).
struct Batch {
  torch::Tensor obs, actions, advantages, logp;
};

// The LVC inner loss, -J_LVC with J_LVC = mean(exp(log pi(a|s) - logp_b) A). logp_b is
// b.logp when defined (the sampling policy, as in ProMP's implementation: the inner step stays
// an importance-weighted policy gradient when the outer loop takes several steps on the same
// rollouts), else stopgrad(log pi(a|s)) itself. At the sampling parameters the ratio is 1, so
// J_LVC = mean(A), its gradient is the vanilla policy gradient and its Hessian is
// mean(A (H log pi + g g^T)) over the rows, g the score: each row's score with itself only,
// without the products of different time steps' scores that make DiCE's Hessian noisy.
torch::Tensor lvc_loss(const FunctionalGaussian& pi, const std::vector<torch::Tensor>& params,
                       const Batch& b);

// ProMP's inner step, params + inner_lr * grad J_LVC(params) (per-parameter sizes: element by
// element, maml.h's StepSize); differentiable (second order)
// when create_graph is true. Chain calls for several inner steps, each on the rollouts of the
// policy adapted so far.
std::vector<torch::Tensor> lvc_inner_step(const FunctionalGaussian& pi,
                                          const std::vector<torch::Tensor>& params,
                                          const Batch& b, const StepSize& inner_lr,
                                          bool create_graph);

// The outer surrogate on the adapted policy's rollouts: rl::clipped_surrogate of
// ratio = exp(log pi_adapted(a|s) - post.logp), post.logp being the log-probability under the
// adapted policy that sampled them (fixed at sampling time).
torch::Tensor promp_surrogate(const FunctionalGaussian& pi,
                              const std::vector<torch::Tensor>& adapted, const Batch& post,
                              double clip);

// KL(pi_old || pi) averaged over the pre-adaptation observations [B, D], the old (sampling)
// pre-adaptation parameters detached: the penalty's gradient moves `params` only.
torch::Tensor promp_kl(const FunctionalGaussian& pi, const std::vector<torch::Tensor>& params_old,
                       const std::vector<torch::Tensor>& params, const torch::Tensor& obs);

// The KL penalty's coefficient eta, adapted after each outer step as in the ProMP paper.
struct AdaptiveKlPenalty {
  double eta = 0;     // the coefficient
  double target = 0;  // the KL aimed at (the seed paper's ProMP table: desired kl 0.016)

  // Doubles eta when kl > 1.5 target, halves it when kl < target / 1.5; returns the new eta.
  double update(double kl);
  torch::Tensor penalty(const torch::Tensor& kl) const { return eta * kl; }
};

struct ProMPConfig {
  double inner_lr = 3e-4;  // the inner step's size (the seed paper's table)
  double clip = 0.2;       // the outer surrogate's clip range
};

// One task's ProMP loss: surrogate + eta kl, with the surrogate and the KL apart for metrics.
struct ProMPTerms {
  torch::Tensor loss, surrogate, kl;
};
// For one task: adapts `params` by one LVC step on the pre-adaptation rollouts `pre`
// (differentiably), scores the adapted policy with promp_surrogate on its rollouts `post`, and
// adds eta * promp_kl(params_old, params) on pre.obs. The meta-objective to minimise is the mean
// of `loss` over the tasks of a meta-batch.
ProMPTerms promp_task_loss(const FunctionalGaussian& pi, const std::vector<torch::Tensor>& params,
                           const std::vector<torch::Tensor>& params_old, const Batch& pre,
                           const Batch& post, const ProMPConfig& config, double eta);

}  // namespace bidex::metarl
