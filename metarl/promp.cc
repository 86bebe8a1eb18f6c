#include "metarl/promp.h"

#include "metarl/maml.h"

namespace bidex::metarl {

torch::Tensor lvc_loss(const FunctionalGaussian& pi, const std::vector<torch::Tensor>& params,
                       const Batch& b) {
  const auto logp = pi.log_prob(params, b.obs, b.actions);
  // one ratio per row over a constant denominator: the gradient is the policy gradient and the
  // Hessian has no products of different rows' scores (DiCE multiplies the ratios of a
  // trajectory's steps, hence its cross terms)
  const auto logp_b = b.logp.defined() ? b.logp.detach() : logp.detach();
  return -(torch::exp(logp - logp_b) * b.advantages.detach()).mean();
}

std::vector<torch::Tensor> lvc_inner_step(const FunctionalGaussian& pi,
                                          const std::vector<torch::Tensor>& params,
                                          const Batch& b, const StepSize& inner_lr,
                                          bool create_graph) {
  const auto p = differentiable(params);
  // descending -J_LVC is ascending J_LVC: params + inner_lr * grad J_LVC
  return gradient_step(lvc_loss(pi, p, b), p, inner_lr, create_graph);
}

torch::Tensor promp_surrogate(const FunctionalGaussian& pi,
                              const std::vector<torch::Tensor>& adapted, const Batch& post,
                              double clip) {
  const auto ratio = torch::exp(pi.log_prob(adapted, post.obs, post.actions) - post.logp.detach());
  return clipped_surrogate(ratio, post.advantages.detach(), clip);
}

torch::Tensor promp_kl(const FunctionalGaussian& pi, const std::vector<torch::Tensor>& params_old,
                       const std::vector<torch::Tensor>& params, const torch::Tensor& obs) {
  std::vector<torch::Tensor> old;
  old.reserve(params_old.size());
  for (const auto& t : params_old) old.push_back(t.detach());
  return pi.kl(old, params, obs);
}

double AdaptiveKlPenalty::update(double kl) {
  if (kl > 1.5 * target) eta *= 2.0;
  else if (kl < target / 1.5) eta /= 2.0;
  return eta;
}

ProMPTerms promp_task_loss(const FunctionalGaussian& pi, const std::vector<torch::Tensor>& params,
                           const std::vector<torch::Tensor>& params_old, const Batch& pre,
                           const Batch& post, const ProMPConfig& config, double eta) {
  const auto adapted = lvc_inner_step(pi, params, pre, config.inner_lr, /*create_graph=*/true);
  ProMPTerms t;
  t.surrogate = promp_surrogate(pi, adapted, post, config.clip);
  t.kl = promp_kl(pi, params_old, params, pre.obs);
  t.loss = t.surrogate + eta * t.kl;
  return t;
}

}  // namespace bidex::metarl
