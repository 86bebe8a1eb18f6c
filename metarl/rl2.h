// RL^2's learner: the recurrent policy (recurrent_policy.h) trained with PPO over rollouts of
// `horizon` steps of every slot. A slot's *trial* is `trial_episodes` consecutive episodes of
// its task: the policy's memory runs through the whole trial and is cleared only when the next
// trial starts, and the return it maximises is the trial's (advantages are cut at trial ends,
// not at episode ends), so exploring in the first episode pays in the later ones.
#pragma once

#include <vector>

#include <torch/torch.h>

#include "metarl/recurrent_policy.h"
#include "metarl/task_scale.h"

namespace bidex::metarl {

struct Rl2Config {
  int hidden_size = 256;      // the GRU's state
  double init_std = 0.8;
  int horizon = 32;           // steps of every slot per update (the gradient runs through them)
  int epochs = 5;
  int minibatches = 4;        // of slots: each minibatch holds whole sequences
  double clip = 0.2;
  double lr = 3e-4;
  double gamma = 0.96;
  double lambda = 0.95;
  double max_grad_norm = 1.0;
  double entropy_coef = 0.0;
  double value_coef = 2.0;
  int trial_episodes = 2;     // episodes of one task per trial
  // The GRU reads observations normalised by a running mean and std, and the previous reward
  // as symlog (RecurrentPolicyImpl::input).
  bool input_norm = false;
  // The learner divides each task's rewards by the running std of that task's discounted
  // returns before the advantages and the critic's targets, so that tasks whose rewards differ
  // by orders of magnitude weigh alike (a suite's tasks do); a scaled reward is clipped to
  // +-10 per step. The policy never sees the scale.
  bool task_reward_norm = false;
};

class Rl2 {
 public:
  Rl2(int64_t obs_dim, int64_t act_dim, int64_t nslot, const Rl2Config& config,
      const torch::Device& device);

  // Sampled actions [N, A] for observations [N, D]; slots whose trial ended at the last
  // observe() start a new one here (memory and previous action, reward and done zeroed).
  torch::Tensor act(const torch::Tensor& obs);
  // The step that followed the last act(): rewards [N] and done flags [N] (episode ends).
  void observe(const torch::Tensor& reward, const torch::Tensor& done);
  // Each slot's task (0 .. ntasks - 1): task_reward_norm keeps one return scale per task
  // (task_scale.h). By default every slot is task 0.
  void set_slot_tasks(const std::vector<int>& slot_task, int ntasks) {
    scale_.set_slot_tasks(slot_task, ntasks);
  }
  // task_reward_norm's per-task return statistics; checkpoints keep them.
  TaskReturnScale& reward_scale() { return scale_; }
  // PPO over the rollout of horizon steps; `obs` are the observations after the last one.
  // Returns policy_loss, value_loss, entropy and the KL to the rollout's policy.
  std::vector<double> update(const torch::Tensor& obs);

  int steps_per_update() const { return c_.horizon; }
  // 1 where a slot's next act() starts a new trial, [N].
  const torch::Tensor& trial_ends() const { return new_trial_; }
  // The memory the next act() starts from, [1, N, H] (before trial resets).
  const torch::Tensor& hidden() const { return hidden_; }
  RecurrentPolicy& policy() { return policy_; }
  torch::optim::Adam& optimizer() { return *opt_; }

 private:
  Rl2Config c_;
  int64_t nslot_;
  RecurrentPolicy policy_;
  std::unique_ptr<torch::optim::Adam> opt_;
  // acting state, per slot
  torch::Tensor hidden_, prev_action_, prev_reward_, prev_done_, episodes_, new_trial_;
  // the rollout, [T, N, ...]: inputs, actions, the policy's means (for the KL metric), their
  // log-probabilities and the values, rewards, trial ends after each step, trial starts before
  // each step; the memory before step 0
  torch::Tensor inputs_, actions_, means_, logp_, values_, rewards_, cuts_, resets_, hidden0_;
  int t_ = 0;
  TaskReturnScale scale_;  // task_reward_norm
};

}  // namespace bidex::metarl
