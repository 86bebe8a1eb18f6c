// The resolved configuration of a training run: defaults from configs/train/<algo>.yaml, the
// file's per-task section, then `-o key=value` overrides, read strictly (unknown keys, wrong
// types and impossible values are ConfigErrors naming the file, key, expected and actual value).
// The resolved YAML is what a run folder keeps as config.yaml and what --resume reads back.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace bidex::rl {

// The on-policy actor-critic settings: the networks, the rollout and the critic, and PPO's
// surrogate (the `ppo:` section; TRPO's `trpo:` section fills the same fields but PPO's own, and
// TrpoConfig).
struct PpoConfig {
  std::vector<int> hidden{1024, 1024, 512};
  std::string activation = "elu";
  double init_std = 0.8;
  int horizon = 8;
  int epochs = 5;
  int minibatches = 4;
  double clip = 0.2;
  double lr = 3e-4;
  std::string schedule = "adaptive";
  double desired_kl = 0.016;
  double gamma = 0.96;
  double lambda = 0.95;
  double max_grad_norm = 1.0;
  double entropy_coef = 0.0;
  double value_coef = 2.0;
  bool clip_value_loss = false;
  double value_clip = 0.2;
  bool obs_norm = true;
  bool value_norm = false;
  // value_norm within each task of a multi-task pack (`value_norm: task`, multi-task PPO; each
  // row's task read from its one-hot id), value_norm then true
  bool value_norm_task = false;
  // PPO and MTPPO on a CUDA device: replay the minibatch step as a CUDA graph (rl/ppo.h)
  bool cuda_graph = true;
  // PPO and MTPPO on a CUDA device: replay the rollout's act step (normalising, acting, sampling,
  // recording) as CUDA graphs, one per step of the horizon (rl/onpolicy.h); false where a run's
  // config predates it, and for TRPO
  bool act_graph = false;
  // PPO and MTPPO: the minibatch step's network products in bfloat16 (rl/autocast.h); the
  // parameters, gradients, optimizer and losses stay float32
  bool bf16 = false;
  // PPO and MTPPO: the rollout's network products (acting, and the critic's bootstrap values) in
  // bfloat16 (rl/onpolicy.h); the rollout's actions, means, values and log-probabilities stay
  // float32; false where a run's config predates it
  bool bf16_act = false;
  // PPO and MTPPO: the actor's and critic's layers of a width not a multiple of 8 (the
  // observation's, the action's, the value's) padded with zeros to one (rl/policy.h, PaddedLinear)
  bool align_widths = false;
  // bf16, bf16_act and align_widths may read `auto` in the YAML: on where the learner runs on
  // CUDA. Until settle_auto() decides them for a device, the flag is set and the value false.
  bool bf16_auto = false, bf16_act_auto = false, align_widths_auto = false;
  // PPO and MTPPO: FlatAdam's fused step (rl/flat_adam.h; where LibTorch has it, 2.4 on)
  bool fused_adam = false;
  // PPO and MTPPO: the layers' bias gradients as matrix products (rl/policy.h,
  // linear_gemm_bias_grad) instead of sums over the rows
  bool bias_grad_gemm = false;
  // advantages normalised over the whole update ("batch") or within each task of a multi-task
  // pack ("task", multi-task PPO: each row's task read from its one-hot id)
  std::string advantage_norm = "batch";
};

// TRPO's natural-gradient step (the `trpo:` section, with the fields of PpoConfig it shares).
struct TrpoConfig {
  double max_kl = 0.1;        // the KL bound of one policy step
  double damping = 0.1;       // added to the Fisher matrix's diagonal in conjugate gradient
  int cg_iters = 3;           // conjugate gradient iterations
  int backtracks = 10;        // line-search trials, each halving the step
  double accept_ratio = 0.01; // least improvement accepted, as a share of the predicted one
  double step_fraction = 1.0; // the first trial's share of the full natural step
};

// SAC (the `sac:` section): the paper's SAC table.
struct SacConfig {
  std::vector<int> hidden{1024, 1024, 1024};  // actor and each of the two critics
  std::string activation = "elu";
  int horizon = 8;            // control steps of every slot between updates
  int minibatches = 4;        // gradient steps per update
  int batch_size = 32;        // transitions per gradient step
  int64_t replay_size = 5000; // transitions the replay buffer keeps
  double lr = 3e-4;           // Adam, actor, critics and temperature
  double gamma = 0.96;
  double polyak = 0.99;       // target critics: polyak x target + (1 - polyak) x critic
  double init_alpha = 0.2;    // the entropy temperature at the start
  bool learn_alpha = true;    // learn it towards the target entropy -act_dim
  double max_grad_norm = 1.0;
  double reward_scale = 1.0;
  // on a CUDA device, once the replay buffer is full: an update's gradient steps replayed as one
  // CUDA graph (rl/cuda_graph.h)
  bool cuda_graph = false;
};

// TD3 and DDPG (the `td3:` and `ddpg:` sections): the paper's tables for them. DDPG uses one
// critic, no target smoothing and no policy delay (its section has no such keys).
struct Td3Config {
  std::vector<int> hidden{1024, 1024, 512};  // actor and each critic
  std::string activation = "elu";
  int horizon = 8;            // control steps of every slot between updates
  int epochs = 5;             // gradient steps per update: epochs x minibatches
  int minibatches = 4;
  int batch_size = 100;       // transitions per gradient step (DDPG's table: 64)
  int64_t replay_size = 10000;
  double lr = 1e-4;           // Adam, actor and critics
  double gamma = 0.96;
  double polyak = 0.995;      // targets: polyak x target + (1 - polyak) x learned
  double max_grad_norm = 1.0;
  double reward_scale = 1.0;
  double act_noise = 0.1;     // exploration: Gaussian noise of this std on the actor's action
  double preact_l2 = 0.0;     // actor loss + this x mean squared pre-tanh action (keeps the
                              // actor off tanh's flat ends; 0: the paper's plain actor loss)
  // TD3 only
  bool twin = true;           // two critics, the minimum in the target
  double target_noise = 0.2;  // target policy smoothing: noise std ...
  double noise_clip = 0.5;    // ... clipped to +- this
  int policy_delay = 2;       // actor and target updates every this many critic steps
  // on a CUDA device, once the replay buffer is full: an update's gradient steps replayed as one
  // CUDA graph (rl/td3.cc)
  bool cuda_graph = false;
};

struct TrainConfig {
  std::string algo = "ppo";
  std::string task;               // a task run: the task id (suite empty)
  std::string suite;              // a suite run (mtppo): the suite id or file (task empty)
  std::string dataset;            // a dataset run (offline): the dataset folder; task is its task
  uint64_t seed = 0;
  int slots = 2048;
  int threads = 0;
  std::string task_config;
  std::string physics;            // physics YAML of every world (empty: configs/sim/physics.yaml)
  int64_t steps = 100000000;
  int save_interval = 100;
  int keep_checkpoints = 3;
  int plot_interval = 10;
  std::string device = "auto";
  int torch_threads = 0;
  bool tf32 = true;  // CUDA matrix products in TF32 (absent from older run configs: true)
  PpoConfig ppo;    // the on-policy settings (ppo, mtppo, trpo)
  TrpoConfig trpo;  // trpo only
  SacConfig sac;    // sac only
  Td3Config td3;    // td3 and ddpg
  // The algorithm's own section as YAML text, for families registered from outside rl
  // (algorithms.h, SectionReader); empty for rl's own.
  std::string section_yaml;

  // slot-steps per update
  int64_t batch() const { return int64_t(slots) * ppo.horizon; }
  // What the run trains on: the task id or the suite.
  const std::string& target() const { return suite.empty() ? task : suite; }
};


// The defaults file of an algorithm: <data dir>/configs/train/<algo>.yaml. Unknown algo:
// ConfigError listing the known ones.
std::string default_train_config(const std::string& algo);

// Builds the resolved YAML text for a new run: `file`'s top-level keys (per_task removed, the
// section of the task or suite merged in), then each "key.path=value" override; adds `algo` and
// `task: <target>` (a task algorithm) or `suite: <target>` (a suite algorithm), and `dataset` for
// an offline algorithm (TrainsOn::kDataset), which must have one.
// A malformed override (no '=', empty key), an unknown key or a value of the wrong type is a
// ConfigError naming the override.
std::string resolve_train_yaml(const std::string& file, const std::string& algo,
                               const std::string& target, const std::vector<std::string>& overrides,
                               const std::string& dataset = "");

// Reads a resolved YAML (as written by resolve_train_yaml) strictly. `name` names it in errors.
TrainConfig parse_train_config(const std::string& yaml_text, const std::string& name);

// A short hash of the resolved YAML text (hex), recorded with every checkpoint.
std::string config_hash(const std::string& yaml_text);

// Decides the settings that read `auto` (ppo.bf16, ppo.bf16_act and ppo.align_widths: on with a
// CUDA learner) for a learner on CUDA (`cuda`) or not: in `c`, and in `yaml_text` where given
// (rewritten only where it held an `auto`), so that a new run's config.yaml says what ran and
// a resumed or loaded run builds the same networks (align_widths sets their shapes, which the
// checkpoints keep).
void settle_auto(TrainConfig& c, bool cuda, std::string* yaml_text = nullptr);

}  // namespace bidex::rl
