// SAC (Haarnoja et al. 2018) on the learning core: a tanh-squashed Gaussian actor with a
// state-dependent std, two critics with Polyak-averaged targets, an entropy temperature learned
// towards the target entropy -act_dim, and the ReplayBuffer. Each update follows `horizon` steps
// of every slot (their transitions added to the buffer) with `minibatches` gradient steps on
// `batch_size` sampled transitions. The actor, the critics and the temperature each step with
// FlatAdam (rl/flat_adam.h; the checkpoint parts actor_optimizer, critic_optimizer and
// alpha_optimizer, which load LibTorch Adam's state of older checkpoints too). The pieces below
// are the losses' formulas, for tests.
#pragma once

#include <memory>

#include <torch/torch.h>

#include "rl/algorithm.h"

namespace bidex::rl {

// The critics' target: r + gamma (1 - terminal) (min(q1', q2') - alpha log pi(a'|s')).
// `alpha` is one value, or one per row (multi-task SAC: each row's task's temperature).
torch::Tensor sac_q_target(const torch::Tensor& reward, const torch::Tensor& terminal,
                           const torch::Tensor& q1_next, const torch::Tensor& q2_next,
                           const torch::Tensor& logp_next, const torch::Tensor& alpha,
                           double gamma);
torch::Tensor sac_q_target(const torch::Tensor& reward, const torch::Tensor& terminal,
                           const torch::Tensor& q1_next, const torch::Tensor& q2_next,
                           const torch::Tensor& logp_next, double alpha, double gamma);
// The temperature's loss: -mean(log_alpha (log pi(a|s) + target_entropy)), its gradient pushing
// the policy's entropy -E[log pi] towards target_entropy. `log_alpha` is one value, or one per row
// (multi-task SAC: each row's task's, so that each task's temperature follows its own entropy).
torch::Tensor sac_alpha_loss(const torch::Tensor& log_alpha, const torch::Tensor& logp,
                             double target_entropy);
// log pi(tanh(u)) of a tanh-squashed Gaussian at the pre-squash sample u, per row: the
// Gaussian's log-density of u minus sum log(1 - tanh(u)^2), the change of variables.
torch::Tensor tanh_gaussian_log_prob(const torch::Tensor& u, const torch::Tensor& mean,
                                     const torch::Tensor& log_std);

std::unique_ptr<Algorithm> make_sac(const TrainConfig& config, int64_t obs_dim, int64_t act_dim,
                                    int64_t nslot, const torch::Device& device);
// Multi-task SAC on a suite's pack (config.suite): SAC with one learned temperature per task of
// the suite's train split, each row's taken from its one-hot task id.
std::unique_ptr<Algorithm> make_mtsac(const TrainConfig& config, int64_t obs_dim,
                                      int64_t act_dim, int64_t nslot,
                                      const torch::Device& device);

}  // namespace bidex::rl
