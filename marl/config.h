// The YAML sections of the multi-agent algorithms (configs/train/ippo.yaml, mappo.yaml,
// happo.yaml, hatrpo.yaml, maddpg.yaml), read strictly: unknown keys and bad values are
// ConfigErrors naming the key. Defaults (the files and these structs agree) are the original
// Bi-DexHands code's (bidexhands/cfg/{ippo,mappo,happo,hatrpo}/config.yaml) and, for MADDPG,
// which the original left untested, HARL's (harl/configs/algos_cfgs/maddpg.yaml) on our rhythm
// of steps between updates.
#pragma once

#include <string>
#include <vector>

#include "core/yaml.h"
#include "rl/config.h"

namespace bidex::marl {

// The networks of every agent's actor and of the critics: LayerNorm over the input
// (feature_norm), then `hidden` layers of `activation`, each followed by LayerNorm (layer_norm),
// orthogonal weights (gain sqrt 2; the actor's output 0.01), zero biases.
struct NetConfig {
  std::vector<int> hidden{512, 512, 512};
  std::string activation = "elu";
  bool feature_norm = true;
  bool layer_norm = true;
};

// IPPO, MAPPO, HAPPO and HATRPO.
// Every multi-agent section also has `agents` (hand, finger or a list: marl/agents.h), which
// the readers check for form and the factories resolve against the task's layout.
struct OnPolicyConfig {
  NetConfig net;
  int horizon = 8;              // control steps of every slot per update
  int epochs = 5;               // PPO epochs (HATRPO: the critic's)
  int minibatches = 1;
  double clip = 0.2;
  double lr = 5e-4;             // actors (Adam); HATRPO's actors take natural steps instead
  double critic_lr = 5e-4;
  double adam_eps = 1e-5;
  double gamma = 0.96;
  double lambda = 0.95;
  double max_grad_norm = 10.0;
  double entropy_coef = 0.0;
  double value_coef = 1.0;
  bool clip_value_loss = true;
  double huber_delta = 10.0;    // value loss: Huber with this delta (0: squared error)
  bool value_norm = true;       // the critic learns normalised returns (running mean and std)
  bool obs_norm = false;        // a running normaliser before the networks (ours; off: original)
  // the Gaussian's std: sigmoid(log_std / std_x_coef) x std_y_coef, log_std learned from
  // log_std_init (1: std 0.366)
  double std_x_coef = 1.0, std_y_coef = 0.5, log_std_init = 1.0;
  bool share_actor = false;     // MAPPO: one actor for all agents (equal widths needed)
  bool fixed_order = false;     // HAPPO, HATRPO: agents in order instead of a random permutation
  // HATRPO's natural step
  double kl_threshold = 0.016;
  int cg_iters = 10;
  double damping = 0.1;
  int backtracks = 10;
  double accept_ratio = 0.5;
};

// MADDPG: deterministic actors on their own observations, one centralised Q(state, joint action)
// with a target, on the core's replay buffer.
struct MaddpgConfig {
  NetConfig net{{128, 128}, "relu", true, false};  // actors and critic
  int horizon = 8;              // control steps of every slot between updates
  int gradient_steps = 4;       // critic steps per update
  int policy_freq = 1;          // actor steps every this many critic steps
  int batch_size = 1000;
  int64_t replay_size = 1000000;
  int64_t warmup_steps = 10000; // slot-steps of uniform random actions before learning
  double lr = 5e-4, critic_lr = 1e-3;
  double gamma = 0.99;
  double polyak = 0.005;        // targets: polyak x learned + (1 - polyak) x target
  double expl_noise = 0.1;      // Gaussian exploration noise on the actors' actions
  double huber_delta = 10.0;    // critic loss (0: squared error)
  double max_grad_norm = 10.0;
  double reward_scale = 1.0;
  double preact_l2 = 0.0;       // actor loss + this x mean squared pre-tanh action (rl/td3.h)
};

// The readers (`algo` picks which keys an on-policy section has: HATRPO's own, MAPPO's
// share_actor, HAPPO's and HATRPO's fixed_order).
OnPolicyConfig read_onpolicy(const YamlView& section, const std::string& algo);
MaddpgConfig read_maddpg(const YamlView& section);

// The config's section (rl::TrainConfig::section_yaml) as a view naming it in errors.
YamlView section_of(const rl::TrainConfig& config);
// The agents of a run: its section's `agents` resolved against its task's layout; an Error
// naming both when the split's widths are not the run's rows' (obs_dim, act_dim).
struct AgentSplit;
AgentSplit run_agents(const rl::TrainConfig& config, int64_t obs_dim, int64_t act_dim);

}  // namespace bidex::marl
