// The offline algorithms' losses and targets as free functions of tensors, so that tests check
// them against hand-worked values. Shapes: B rows of a batch, A action components.
#pragma once

#include <torch/torch.h>

namespace bidex::offline {

// BC: mean squared error of the actor's actions pi [B, A] to the dataset's a [B, A].
torch::Tensor bc_loss(const torch::Tensor& pi, const torch::Tensor& a);

// TD3+BC's actor loss -lambda mean(q) + mean((pi - a)^2) with lambda = alpha / mean|q| held
// constant (no gradient through it); q [B] is the first critic's value of pi [B, A].
struct Td3bcActorLoss {
  torch::Tensor loss;
  torch::Tensor bc_mse;  // mean((pi - a)^2), for the metric
};
Td3bcActorLoss td3bc_actor_loss(const torch::Tensor& q, const torch::Tensor& pi,
                                const torch::Tensor& a, double alpha);

// BCQ's VAE loss: MSE(recon, a) + 0.5 KL, KL = -0.5 mean(1 + log sigma^2 - mean^2 - sigma^2)
// (the mean over every latent component, as the original); sigma is the encoder's std.
torch::Tensor bcq_vae_loss(const torch::Tensor& recon, const torch::Tensor& a,
                           const torch::Tensor& mean, const torch::Tensor& sigma);
// BCQ's critics' target for B next states with `repeats` sampled actions each, q1 and q2
// [B x repeats] in state-major order (repeat_interleave): per sample lmbda min + (1 - lmbda) max
// of the two, the best sample per state, then reward + not_done gamma x that ([B]).
torch::Tensor bcq_target(const torch::Tensor& q1, const torch::Tensor& q2, double lmbda,
                         const torch::Tensor& reward, const torch::Tensor& not_done,
                         double gamma, int64_t repeats);
// BCQ's action selection: per row of q [n, K] the candidate [n, K, A] of the largest value.
torch::Tensor bcq_pick(const torch::Tensor& q, const torch::Tensor& candidates);

// IQL's value loss mean(|expectile - 1(u < 0)| u^2), u = Q - V. The original writes it as
// mean(|expectile u^2 + relu(-u) u|), which is the same function (offline/iql.cc).
torch::Tensor iql_expectile_loss(const torch::Tensor& u, double expectile);
// IQL's advantage weights min(exp(beta (q - v)), max_weight), [B].
torch::Tensor iql_policy_weights(const torch::Tensor& q, const torch::Tensor& v, double beta,
                                 double max_weight);
// The log-density of actions a [B, A] in (-1, 1) per component under tanh of a Normal of
// `mean` [B, A] and variance exp(log_var) [A]: log N(atanh a; mean, std) - log(1 - a^2).
torch::Tensor iql_log_prob(const torch::Tensor& a, const torch::Tensor& mean,
                           const torch::Tensor& log_var);
// IQL's policy loss -mean(w log_prob): weights w [B], log_prob [B, A], averaged over both axes
// as the original (its density is per component, not summed over the action).
torch::Tensor iql_policy_loss(const torch::Tensor& w, const torch::Tensor& log_prob);

}  // namespace bidex::offline
