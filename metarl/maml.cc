#include "metarl/maml.h"

#include <stdexcept>
#include <string>

namespace bidex::metarl {

torch::Tensor pg_loss(const FunctionalGaussian& pi, const std::vector<torch::Tensor>& params,
                      const torch::Tensor& obs, const torch::Tensor& actions,
                      const torch::Tensor& advantages) {
  // advantages are data: a critic's output must not receive the policy's gradient
  return -(pi.log_prob(params, obs, actions) * advantages.detach()).mean();
}

std::vector<torch::Tensor> differentiable(const std::vector<torch::Tensor>& params) {
  std::vector<torch::Tensor> p;
  p.reserve(params.size());
  for (const auto& t : params)
    p.push_back(t.requires_grad() ? t : t.detach().set_requires_grad(true));
  return p;
}

std::vector<torch::Tensor> gradient_step(const torch::Tensor& loss,
                                         const std::vector<torch::Tensor>& params,
                                         const StepSize& lr, bool create_graph) {
  if (!lr.per_param.empty() && lr.per_param.size() != params.size())
    throw std::invalid_argument("gradient_step: " + std::to_string(lr.per_param.size()) +
                                " step sizes for " + std::to_string(params.size()) +
                                " parameters");
  const auto grads = torch::autograd::grad({loss}, params, /*grad_outputs=*/{},
                                           /*retain_graph=*/create_graph,
                                           /*create_graph=*/create_graph);
  std::vector<torch::Tensor> out;
  out.reserve(params.size());
  for (size_t i = 0; i < params.size(); ++i)
    out.push_back(lr.per_param.empty() ? params[i] - lr.lr * grads[i]
                                       : params[i] - lr.per_param[i] * grads[i]);
  return out;
}

std::vector<torch::Tensor> inner_step(const FunctionalGaussian& pi,
                                      const std::vector<torch::Tensor>& params,
                                      const torch::Tensor& obs, const torch::Tensor& actions,
                                      const torch::Tensor& advantages, const StepSize& inner_lr,
                                      bool create_graph) {
  const auto p = differentiable(params);
  return gradient_step(pg_loss(pi, p, obs, actions, advantages), p, inner_lr, create_graph);
}

std::vector<torch::Tensor> inner_steps(const FunctionalGaussian& pi,
                                       const std::vector<torch::Tensor>& params,
                                       const torch::Tensor& obs, const torch::Tensor& actions,
                                       const torch::Tensor& advantages, const StepSize& inner_lr,
                                       int steps, bool create_graph) {
  auto p = params;
  for (int k = 0; k < steps; ++k)
    p = inner_step(pi, p, obs, actions, advantages, inner_lr, create_graph);
  return p;
}

}  // namespace bidex::metarl
