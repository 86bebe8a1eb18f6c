// PPO (clipped surrogate, optional clipped value loss, KL-adaptive learning rate, minibatches,
// epochs, gradient-norm clipping, entropy bonus) over a rollout of `horizon` steps of every
// slot, with GAE advantages. Everything lives on the device of the actor-critic, and the epochs
// never wait for it: the optimiser (FlatAdam), the gradient clip and the adaptive learning rate
// run on the device, and the statistics are read back once per update.
#pragma once

#include <memory>

#include <torch/torch.h>

#include "rl/algorithm.h"
#include "rl/config.h"
#include "rl/flat_adam.h"
#include "rl/policy.h"
#include "rl/stage_timer.h"

namespace bidex::rl {

// One rollout, [T, N, ...] tensors on the training device.
struct Rollout {
  Rollout(int64_t horizon, int64_t nslot, int64_t obs_dim, int64_t act_dim,
          const torch::Device& device);
  torch::Tensor nobs;      // observations as the policy saw them (normalised), [T, N, D]
  torch::Tensor actions;   // sampled (unclipped) actions, [T, N, A]
  torch::Tensor logp;      // their log-probability, [T, N]
  torch::Tensor mu;        // the policy's mean, [T, N, A]
  torch::Tensor values;    // critic, return units, [T, N]
  torch::Tensor rewards;   // reward (+ gamma V(final obs) where the time limit cut the episode)
  torch::Tensor dones;     // 1 where the episode ended at this step (either way), [T, N]
  torch::Tensor log_std;   // the policy's log-std during the rollout, [A]
  int64_t horizon, nslot;
};

// Generalised advantage estimation. `dones[t]` cuts the recursion after step t; `last_value` is
// V(obs after the last step). Returns (advantages, returns), both [T, N].
std::pair<torch::Tensor, torch::Tensor> gae(const torch::Tensor& rewards,
                                            const torch::Tensor& values,
                                            const torch::Tensor& dones,
                                            const torch::Tensor& last_value, double gamma,
                                            double lambda);

// PPO's clipped surrogate as a loss to minimise: -mean(min(r A, clamp(r, 1 - clip, 1 + clip) A))
// for probability ratios r and advantages A of the same shape.
torch::Tensor clipped_surrogate(const torch::Tensor& ratio, const torch::Tensor& advantages,
                                double clip);

// PPO's KL-adaptive learning rate, on the device (no read back): `lr` (0-dim float64, updated in
// place) / 1.5, at least 1e-5, where the mean KL `kl` (0-dim) of a minibatch exceeds
// 2 desired_kl; x 1.5, at most 1e-2, where it is positive and below desired_kl / 2.
void adapt_lr(const torch::Tensor& lr, const torch::Tensor& kl, double desired_kl);

// Advantages normalised to mean 0 and standard deviation 1 (unbiased, + 1e-8): over all rows,
// or, given each row's group in `groups` ([B] integers below `ngroups`), within each group. On
// the device, with nothing read back; a group of one row keeps its advantage less its mean (0).
torch::Tensor normalize_advantages(const torch::Tensor& adv,
                                   const torch::Tensor& groups = {}, int64_t ngroups = 1);

struct UpdateStats {
  double policy_loss = 0, value_loss = 0, entropy = 0, kl = 0, lr = 0, clip_fraction = 0;
};

class Ppo {
 public:
  // ntasks: a multi-task pack's task count where config.advantage_norm is "task" (advantages
  // normalised within each task) or config.value_norm_task (the returns, by the model's grouped
  // value normaliser), each row's task read from the last ntasks columns of its observation
  Ppo(ActorCritic model, const PpoConfig& config, int64_t ntasks = 0);
  ~Ppo();

  // Runs the epochs and minibatches over `r`, `last_value` = V(obs after the rollout).
  UpdateStats update(const Rollout& r, const torch::Tensor& last_value);

  // the optimiser, which holds the adaptive learning rate
  FlatAdam& optimizer() { return opt_; }
  // Times update()'s stages from now on (gae, prepare, forward, kl_check, backward, clip_grad,
  // optimizer, stats, read_stats; with a CUDA graph, graph_step in place of forward ... stats)
  // and counts its host synchronisations (one: read_stats).
  StageTimer& timer() { return timer_; }

 private:
  // The rows an update's minibatches draw from, [B, ...] on the device.
  struct Rows {
    torch::Tensor nobs, actions, logp_old, mu_old, log_std_old, advantages, targets, values_old;
  };
  struct Graph;
  // One minibatch's gradient step on the rows `idx`: the KL-adaptive rate, the losses, backward,
  // the clip, Adam, and the statistics added to sums_. It reads nothing back, so a CUDA graph
  // can capture it. `timed`: mark the profile's stages (never while capturing).
  void minibatch(const Rows& rows, const torch::Tensor& idx, bool timed);
  // The epochs of shuffled minibatches; with `idx_buffer` (the graph's), each minibatch's rows
  // are copied into it and the graph replays (or, before the capture, runs eagerly on it).
  void epochs(const Rows& rows, int64_t B, const torch::Tensor* idx_buffer);
  // The epochs on the graph's stream, capturing the step once the stream is warm.
  void graphed_epochs(const Rows& rows, int64_t B);
  // ppo.bf16: the update's observations cast once to the networks' input, bfloat16 and padded
  // to model->input_width() (one buffer, kept while the rollout's size is), so that no
  // minibatch casts or pads its rows twice, for the actor and for the critic.
  const torch::Tensor& bf16_input(const torch::Tensor& nobs);

  ActorCritic model_;
  PpoConfig c_;
  int64_t ntasks_;  // > 0: advantages or returns normalised per task
  FlatAdam opt_;
  StageTimer timer_;
  torch::Tensor sums_;  // policy loss, value loss, entropy, clip fraction, KL (float64)
  std::unique_ptr<Graph> graph_;
  torch::Tensor obs_bf16_;  // bf16_input()'s buffer
};

// PPO behind the learning core's Algorithm interface (mtppo is the same on a suite's pack):
// `horizon` steps into a Rollout, bootstrapping time limits from the critic, then Ppo::update.
// Its checkpoint state is the actor-critic with its normalisers ("model") and FlatAdam
// ("optimizer", the adaptive learning rate included).
std::unique_ptr<Algorithm> make_ppo(const TrainConfig& config, int64_t obs_dim, int64_t act_dim,
                                    int64_t nslot, const torch::Device& device);

}  // namespace bidex::rl
