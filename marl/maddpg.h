// MADDPG (Lowe et al. 2017) on the learning core, as HARL runs it on cooperative tasks: one
// deterministic tanh actor per agent on its observation view, one centralised critic
// Q(full observation, joint action) shared by all agents (the reward is theirs together), target
// copies of every network, and the core's replay buffer of full rows. Until `warmup_steps`
// slot-steps are stored the agents act uniformly at random; then each acts with its actor plus
// Gaussian noise. Each update: `gradient_steps` critic steps towards
// r + gamma (1 - terminal) Q'(s', every agent's target action on its own view of s'), and every
// `policy_freq` of them one step of each actor in turn on -Q(s, joint action) where the joint
// action is the batch's with that agent's columns from its actor, then Polyak targets.
// The replay buffer is not checkpointed (as TD3's): a resumed run refills it before learning.
#pragma once

#include <memory>
#include <vector>

#include <torch/torch.h>

#include "marl/agents.h"
#include "marl/config.h"
#include "marl/nets.h"
#include "rl/algorithm.h"
#include "rl/replay.h"

namespace bidex::marl {

// The critic's target: r + gamma (1 - terminal) q_next, all [B].
torch::Tensor maddpg_q_target(const torch::Tensor& reward, const torch::Tensor& terminal,
                              const torch::Tensor& q_next, double gamma);
// The joint action of agent i's actor step: the batch's `actions` [B, A] with agent i's columns
// set to `own` [B, act_dim(i)] (gradients flow to `own` only).
torch::Tensor maddpg_joint_action(const AgentViews& views, const torch::Tensor& actions,
                                  int64_t i, const torch::Tensor& own);

class Maddpg final : public rl::Algorithm {
 public:
  // `nslot` 0: acting only (evaluation, render), no replay buffer.
  Maddpg(const MaddpgConfig& config, const AgentSplit& split, int64_t nslot,
         const torch::Device& device);

  int steps_per_update() const override { return c_.horizon; }
  torch::Tensor act(const torch::Tensor& obs) override;
  void observe(const rl::Transition& t) override;
  std::vector<double> update(const torch::Tensor& obs) override;
  const std::vector<std::string>& metric_names() const override;
  void save(torch::serialize::OutputArchive& root) override;
  void load(torch::serialize::InputArchive& root, const std::string& path) override;
  void load_actor(torch::serialize::InputArchive& root, const std::string& path) override;
  torch::Tensor actor(const torch::Tensor& obs) override;
  torch::Tensor sample_actor(const torch::Tensor& obs) override;

  // The parts of an update, for tests. The critic's target values [B] of a batch:
  torch::Tensor critic_target(const rl::ReplayBuffer::Batch& b);
  // One critic step; returns (loss, mean Q of the batch's own actions), detached.
  std::pair<torch::Tensor, torch::Tensor> critic_step(const rl::ReplayBuffer::Batch& b);
  // One step of agent i's actor (only its parameters move); returns the loss, detached.
  torch::Tensor actor_step(int64_t i, const rl::ReplayBuffer::Batch& b);
  // The targets' Polyak step, every actor and the critic.
  void update_targets();
  // Q(obs, actions) [n] of the learned critic.
  torch::Tensor q(const torch::Tensor& obs, const torch::Tensor& actions);

  const AgentViews& views() const { return views_; }
  TanhActor& agent_actor(int64_t i) { return actors_[i]; }
  TanhActor& target_actor(int64_t i) { return actor_targets_[i]; }
  ValueNet& critic_net() { return critic_; }
  ValueNet& target_critic() { return critic_target_; }
  rl::ReplayBuffer* replay() { return replay_.get(); }
  int64_t collected() const { return collected_; }  // slot-steps stored over the run
  bool warming_up() const { return collected_ < c_.warmup_steps; }

 private:
  torch::Tensor explore(const torch::Tensor& obs);  // actors + noise, clamped

  MaddpgConfig c_;
  AgentViews views_;
  torch::Device device_;
  // the actors live in lists too (saved as one part each; their targets' Polyak step in one go)
  // every agent's action of `actors` on its view of `obs`, assembled
  torch::Tensor joint(std::vector<TanhActor>& actors, const torch::Tensor& obs) const;
  std::vector<TanhActor> actors_, actor_targets_;
  torch::nn::ModuleList actor_list_, target_list_;
  ValueNet critic_{nullptr}, critic_target_{nullptr};
  std::vector<std::unique_ptr<torch::optim::Adam>> actor_opts_;
  std::unique_ptr<torch::optim::Adam> critic_opt_;
  std::unique_ptr<rl::ReplayBuffer> replay_;
  int64_t collected_ = 0;       // slot-steps stored (warmup; checkpointed)
  int64_t gradient_steps_ = 0;  // critic steps over the run (policy_freq's phase; checkpointed)
  torch::Tensor last_obs_, last_act_;
};

}  // namespace bidex::marl
