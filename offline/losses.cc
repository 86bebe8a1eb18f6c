#include "offline/losses.h"

#include <cmath>

namespace bidex::offline {

torch::Tensor bc_loss(const torch::Tensor& pi, const torch::Tensor& a) {
  return (pi - a).pow(2).mean();
}

Td3bcActorLoss td3bc_actor_loss(const torch::Tensor& q, const torch::Tensor& pi,
                                const torch::Tensor& a, double alpha) {
  // lambda normalises the Q term's scale so that alpha trades it against the BC term alike for
  // any reward scale; it is a weight, not something to optimise
  const auto lambda = alpha / q.detach().abs().mean();
  auto mse = bc_loss(pi, a);
  return {-lambda * q.mean() + mse, mse.detach()};
}

torch::Tensor bcq_vae_loss(const torch::Tensor& recon, const torch::Tensor& a,
                           const torch::Tensor& mean, const torch::Tensor& sigma) {
  const auto var = sigma.pow(2);
  const auto kl = -0.5 * (1 + var.log() - mean.pow(2) - var).mean();
  return (recon - a).pow(2).mean() + 0.5 * kl;
}

torch::Tensor bcq_target(const torch::Tensor& q1, const torch::Tensor& q2, double lmbda,
                         const torch::Tensor& reward, const torch::Tensor& not_done,
                         double gamma, int64_t repeats) {
  const auto q = lmbda * torch::min(q1, q2) + (1 - lmbda) * torch::max(q1, q2);
  const auto best = std::get<0>(q.view({-1, repeats}).max(1));
  return reward + not_done * gamma * best;
}

torch::Tensor bcq_pick(const torch::Tensor& q, const torch::Tensor& candidates) {
  const int64_t n = candidates.size(0), A = candidates.size(2);
  const auto idx = q.argmax(1).view({n, 1, 1}).expand({n, 1, A});
  return candidates.gather(1, idx).squeeze(1);
}

torch::Tensor iql_expectile_loss(const torch::Tensor& u, double expectile) {
  // weight expectile above the prediction, 1 - expectile below it
  const auto w = (u < 0).to(u.scalar_type()) * (1 - 2 * expectile) + expectile;
  return (w * u.pow(2)).mean();
}

torch::Tensor iql_policy_weights(const torch::Tensor& q, const torch::Tensor& v, double beta,
                                 double max_weight) {
  return torch::exp(beta * (q - v)).clamp_max(max_weight);
}

torch::Tensor iql_log_prob(const torch::Tensor& a, const torch::Tensor& mean,
                           const torch::Tensor& log_var) {
  const auto x = torch::atanh(a);
  const auto normal = -0.5 * (x - mean).pow(2) * torch::exp(-log_var) - 0.5 * log_var -
                      0.5 * std::log(2 * M_PI);
  // log |d tanh(x) / dx| = log(1 - tanh(x)^2), in the form that stays finite for large |x|
  const auto log_det = 2 * (std::log(2.0) - x - torch::nn::functional::softplus(-2 * x));
  return normal - log_det;
}

torch::Tensor iql_policy_loss(const torch::Tensor& w, const torch::Tensor& log_prob) {
  return -(w.unsqueeze(1) * log_prob).mean();
}

}  // namespace bidex::offline
