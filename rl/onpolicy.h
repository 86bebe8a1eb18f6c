// The part of every on-policy Gaussian actor-critic algorithm (PPO, TRPO) that is not its
// update: acting with a sampled Gaussian action, recording the rollout (observations as the
// policy saw them, actions, log-probabilities, means, values), bootstrapping time-limited
// episodes from the critic, and the deterministic actor. Subclasses write update() and their
// checkpoint state.
#pragma once

#include <memory>

#include "rl/algorithm.h"
#include "rl/policy.h"
#include "rl/ppo.h"

namespace bidex::rl {

class GaussianOnPolicy : public Algorithm {
 public:
  // value_tasks: the pack's task count where the critic's returns are normalised per task
  GaussianOnPolicy(const PpoConfig& config, int64_t obs_dim, int64_t act_dim, int64_t nslot,
                   const torch::Device& device, int64_t value_tasks = 0);
  ~GaussianOnPolicy() override;

  int steps_per_update() const override { return c_.horizon; }
  torch::Tensor act(const torch::Tensor& obs) override;
  void observe(const Transition& t) override;
  void load_actor(torch::serialize::InputArchive& root, const std::string& path) override;
  torch::Tensor actor(const torch::Tensor& obs) override;
  torch::Tensor sample_actor(const torch::Tensor& obs) override;

 protected:
  // V(obs after the rollout), and afterwards: the next act() starts a new rollout
  torch::Tensor finish_rollout(const torch::Tensor& obs);
  double action_std() const;

  PpoConfig c_;
  ActorCritic model_;
  std::unique_ptr<Rollout> ro_;

 private:
  // act()'s work: normalises `obs` (updating the normaliser), samples the actions and writes the
  // rollout's rows t_; the rows' addresses depend on t_ only, so that a CUDA graph can replay it
  void act_into_rollout(const torch::Tensor& obs);
  // the critic's value of raw observations, as the rollout records it (ppo.bf16_act: its products
  // in bfloat16), float32
  torch::Tensor rollout_value(const torch::Tensor& obs);
  // act_into_rollout replayed as one CUDA graph per rollout step (ppo.act_graph, GraphedSteps of
  // rl/cuda_graph.h): the first rollout runs eagerly on side streams, the second captures there
  struct ActGraphs;
  torch::Tensor graphed_act(const torch::Tensor& obs);

  torch::Tensor std_;  // the rollout's action deviation, written in place at its first step
  int64_t t_ = 0;  // the rollout step the next act() fills
  std::unique_ptr<ActGraphs> graphs_;
};

}  // namespace bidex::rl
