// The on-policy multi-agent family, one algorithm in four modes over a split's agents:
//   IPPO    every agent's PPO with its own critic on its own view (decentralised values);
//   MAPPO   every agent's PPO (or one shared actor) and one critic on the full observation;
//   HAPPO   MAPPO's networks; the agents update one after another in a random permutation,
//           each weighting its surrogate by the probability ratios of the agents before it;
//   HATRPO  HAPPO's sequence, each agent taking one natural-gradient step (rl::natural_step).
// The rollout keeps the full rows ([T, N, D] observations, [T, N, A] actions) and each agent's
// log-probability; views and action parts are index selections on the device (agents.h).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <torch/torch.h>

#include "marl/agents.h"
#include "marl/config.h"
#include "marl/nets.h"
#include "rl/algorithm.h"
#include "rl/policy.h"
#include "rl/trpo.h"

namespace bidex::marl {

enum class OnPolicyMode { kIndependent, kCentralised, kSequentialPpo, kSequentialTrpo };

// One actor's share of a rollout, flattened over steps and slots (B rows).
struct AgentBatch {
  torch::Tensor obs;          // [B, d] its view of the observations (normalised when obs_norm)
  torch::Tensor actions;      // [B, a] its sampled actions
  torch::Tensor logp_old;     // [B] their log-probability during the rollout
  torch::Tensor mu_old;       // [B, a] the rollout policy's means
  torch::Tensor log_std_old;  // [a] the rollout policy's log-std
  torch::Tensor adv;          // [B] advantages (normalised)
};

// HAPPO's surrogate as a loss: -mean(factor x min(r A, clamp(r, 1 - clip, 1 + clip) A)) for the
// agent's ratios r; the factor (the ratios of the agents updated before it, positive) stands
// outside the min. An undefined factor gives PPO's clipped surrogate.
torch::Tensor happo_surrogate(const torch::Tensor& ratio, const torch::Tensor& adv,
                              const torch::Tensor& factor, double clip);
// HATRPO's surrogate as a loss: -mean(factor x r x A).
torch::Tensor hatrpo_surrogate(const torch::Tensor& ratio, const torch::Tensor& adv,
                               const torch::Tensor& factor);
// The factor after an agent's update: factor x exp(logp_new - logp_old), detached.
torch::Tensor next_factor(const torch::Tensor& factor, const torch::Tensor& logp_new,
                          const torch::Tensor& logp_old);

// One actor's PPO update: `epochs` x `minibatches` Adam steps on happo_surrogate (factor may be
// undefined) - entropy_coef x entropy, gradient norm clipped at max_grad_norm. Returns, as a
// [4] float64 tensor on the device, the means over its steps of the policy loss and entropy
// (before each step), KL(rollout policy || policy before the step) and the clipped share.
torch::Tensor ppo_actor_update(GaussianActor& actor, torch::optim::Optimizer& opt,
                               const AgentBatch& b, const torch::Tensor& factor,
                               const OnPolicyConfig& c);
// One actor's natural step on hatrpo_surrogate within kl_threshold (cg_iters, damping,
// backtracks, accept_ratio; the full step first).
rl::NaturalStep trpo_actor_update(GaussianActor& actor, const AgentBatch& b,
                                  const torch::Tensor& factor, const OnPolicyConfig& c);

class OnPolicyMarl final : public rl::Algorithm {
 public:
  // `algo` names the section in errors (mappo.share_actor with agents of unequal widths).
  OnPolicyMarl(OnPolicyMode mode, const OnPolicyConfig& config, const AgentSplit& split,
               int64_t nslot, const torch::Device& device, const std::string& algo);

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

  // The critics' values [n, C] of observations [n, D] in return units: C is the number of
  // agents (IPPO, column i agent i's critic) or 1 (the centralised critic).
  torch::Tensor values(const torch::Tensor& obs);
  int64_t agents() const { return views_.count(); }
  int64_t actors() const { return static_cast<int64_t>(actors_.size()); }

 private:
  torch::Tensor normalize_obs(const torch::Tensor& obs) const;
  // on normalised observations and their agents' views
  torch::Tensor critic_values(const torch::Tensor& nobs, const std::vector<torch::Tensor>& view);
  std::vector<torch::Tensor> agent_views(const torch::Tensor& nobs) const;
  GaussianActor& actor_of(int64_t agent) { return actors_[shared_ ? 0 : agent]; }

  OnPolicyMode mode_;
  OnPolicyConfig c_;
  AgentViews views_;
  bool shared_ = false;  // one actor for all agents
  int64_t T_, N_, D_, A_, C_;

  std::vector<GaussianActor> actors_;
  std::vector<ValueNet> critics_;
  std::vector<rl::RunningNorm> value_norms_;  // one per critic
  torch::nn::ModuleList actor_list_, critic_list_, value_norm_list_;
  rl::RunningNorm obs_norm_{nullptr};
  std::vector<std::unique_ptr<torch::optim::Adam>> actor_opts_, critic_opts_;

  // the rollout, [T, N, ...] on the device
  torch::Tensor obs_, actions_, mu_, logp_, values_, rewards_, dones_;
  std::vector<torch::Tensor> log_std_old_, std_old_;  // per actor, fixed during a rollout
  int64_t t_ = 0;
};

}  // namespace bidex::marl
