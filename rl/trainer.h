// The training workflow of `bidex train --algo ppo`, `bidex eval` and `bidex render --run`: a
// run folder holding the resolved config (config.yaml), run.json, metrics (CSV and JSONL), a
// learning curve (SVG) redrawn while training, and checkpoints written atomically every
// save_interval updates, at the end and on SIGINT/SIGTERM. A run resumes from its newest
// checkpoint.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "rl/config.h"

namespace at {
class Tensor;  // torch::Tensor, without LibTorch's headers here
}

namespace bidex::taskpack {
class Pack;
class TaskPack;
struct PackSpec;
struct PackOptions;
struct WarpPackOptions;
}

namespace bidex::rl {

class Adaptive;
struct Transition;

// The mean return and success rate of one task of a run (a suite run has one per entry).
struct EntryScore {
  std::string label, task;
  double mean_return = 0;   // NaN when no episode ended
  double success = 0;       // NaN when no episode ended
  int64_t episodes = 0;
};

// Sees every step of a training run from its first (bidex train --record-replay writes them as
// a dataset): the observations after the reset, then each step's actions and what it gave, from
// a collector in record mode (Transition::truncated and end_obs are set).
class StepRecorder {
 public:
  virtual ~StepRecorder() = default;
  virtual void begin(const at::Tensor& obs) = 0;
  // false once it has recorded all it wants: the runner then calls finish() and stops calling
  virtual bool step(const at::Tensor& actions, const Transition& t) = 0;
  // Writes what was recorded (also when the run stops early).
  virtual void finish() = 0;
};
using RecorderFactory =
    std::function<std::unique_ptr<StepRecorder>(const TrainConfig&, const taskpack::Pack&)>;

struct TrainOptions {
  bool progress = true;           // the progress bar on stderr
  int64_t stop_after_updates = 0; // > 0: stop as Ctrl-C would after this many updates in total
  double time_limit_s = 0;        // > 0: stop as Ctrl-C would once this session trained this long
  // > 0: stop as Ctrl-C would once monotonic_seconds() reaches it, setup included (bidex train
  // --wall-limit); the first update always runs
  double stop_at_monotonic_s = 0;
  std::string command;            // recorded in run.json
  // Where the simulation steps: cpu (MuJoCo on all cores), cuda (MuJoCo Warp on the GPU, the
  // learner reading its rows in place), auto (cuda when the GPU backend, a GPU and a CUDA
  // LibTorch are present and every task's stages run there), or warp-cpu (the GPU path's code
  // on Warp's CPU device: tests). Recorded per session in run.json.
  std::string device = "auto";
  // Also time the parts of each step (the simulation waits after each stage) and write
  // <run>/profile.json: physics, task kernels, policy and update seconds and slot-steps/s.
  bool profile = false;
  // Called once the run folder holds config.yaml and run.json, before the first step (bidex
  // train records the run in the registry there).
  std::function<void(const TrainConfig&, const std::string& run_dir)> on_start;
  // Set: records the run's steps from the first (a new run only).
  RecorderFactory recorder;
};

struct TrainResult {
  std::string run_dir;
  int64_t updates = 0, steps = 0;
  bool interrupted = false;       // stopped by a signal or stop_after_updates
  double last_return = 0;         // mean return of the episodes of the last updates (NaN: none)
  double last_success = 0;
  std::string checkpoint;         // the newest checkpoint written
  std::string sim_device;         // where the simulation stepped (cpu, cuda, warp-cpu)
  std::string room_advice;        // GPU: which physics settings to raise, if worlds overflowed
  // Per task (a suite run: per entry), the episodes that ended in its last 10 updates in which
  // any ended (rl/recent_scores.h).
  std::vector<EntryScore> scores;
};

// Starts a new run in `run_dir` (created; an existing non-empty folder is an error, nothing in it
// is touched) from a resolved YAML (resolve_train_yaml).
TrainResult train_new(const std::string& resolved_yaml, const std::string& run_dir,
                      const TrainOptions& options);

// Continues the run in `run_dir` from its newest checkpoint, up to its configured steps.
TrainResult train_resume(const std::string& run_dir, const TrainOptions& options);

// The pack evaluation and render run a trained policy on: `per_task` slots per entry of the
// `split` (train or test) of the run's suite, or its task alone (a task run; `split` unused);
// with `per_goal`, `per_task` slots per goal of an entry's goal distribution.
taskpack::PackSpec eval_pack(const TrainConfig& config, const std::string& split, int per_task,
                             bool per_goal);

// The options of every pack that steps a run's worlds (training, evaluation, render, offline
// collection): the run's own physics (env.physics), `seed`, and on the CPU `threads`, on the
// GPU backend `device`.
taskpack::PackOptions run_pack_options(const TrainConfig& config, uint64_t seed, int threads);
taskpack::WarpPackOptions run_warp_pack_options(const TrainConfig& config, uint64_t seed,
                                                const std::string& device);

// The default folder of a new run: runs/<task or suite>-<algo>-<YYYYmmdd-HHMMSS>-s<seed>.
std::string default_run_dir(const TrainConfig& c);

// A trained policy loaded from a run folder (its config.yaml and a checkpoint, default the
// newest), acting deterministically (the Gaussian's mean) or sampling, on the CPU unless asked.
class LoadedPolicy {
 public:
  // `device`: where it acts (cpu or cuda; act() is on the CPU either way).
  LoadedPolicy(const std::string& run_dir, const std::string& checkpoint = "",
               const std::string& device = "cpu");
  ~LoadedPolicy();
  const TrainConfig& config() const;
  const std::string& checkpoint() const;
  int64_t obs_dim() const;
  int64_t act_dim() const;
  int64_t update() const;
  // n rows of obs_dim observations -> n rows of act_dim actions (the mean, clipped to [-1, 1]).
  void act(const float* obs, int n, float* actions);
  // Actions [n, A] for observations [n, D] on its device: the deterministic ones, or with
  // `sample` the policy's sampled ones (Algorithm::sample_actor).
  at::Tensor act(const at::Tensor& obs, bool sample);
  // Meta-RL's adaptation (algorithm.h); null when the run's algorithm does not adapt.
  Adaptive* adaptive();
  // An Error unless `pack` (`what`, e.g. "the test split of ML4") has this checkpoint's
  // observation and action widths.
  void check_fits(const taskpack::Pack& pack, const std::string& what) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// LibTorch's CPU threads (process-wide; 0 keeps its default, every core). bidex eval --threads
// sets them with the simulation's: at the default beside other processes, the sweep's
// evaluations ran at about 170 world-steps/s (bench/results/sweep-h100x4/README.md).
void set_policy_threads(int threads);

struct EvalResult {
  int episodes = 0;
  // a task run: over its episodes; a suite run: the mean over the suite's tasks of theirs
  double mean_return = 0, std_return = 0, mean_length = 0, success_rate = 0;
  int64_t faults = 0;
  std::vector<EntryScore> per_task;  // one per task (unscaled returns)
};

// Runs `episodes` slots for one episode each with the policy's mean action (a suite run:
// `episodes` per task of its train split). `task_config`, for a task run: another YAML of the
// run's task to play (e.g. the task's own after a run that trained under a curriculum); empty:
// the run's own. `progress`: a progress bar of the finished episodes on stderr (the commands').
EvalResult evaluate(LoadedPolicy& policy, int episodes, uint64_t seed, int threads,
                    const std::string& task_config = "", bool progress = false);

// The same with actions uniform in [-1, 1] (a random policy, drawn from `seed`): the reference
// "random" score of a task or suite. Only the config's task or suite (and task_config) are used.
// `split` (train or test) picks a suite's split.
EvalResult evaluate_random(const TrainConfig& config, int episodes, uint64_t seed, int threads,
                           const std::string& split = "train", bool progress = false);

// The same with every action component 0 (bidex play --policy zero): no base force or torque,
// each joint at the target that action 0 means in its task. A baseline for tasks whose random
// score comes from how long a random policy keeps an episode going (ML20's lift_underarm).
EvalResult evaluate_zero(const TrainConfig& config, int episodes, uint64_t seed, int threads,
                         const std::string& split = "train", bool progress = false);

// The same with any actor: `make_actor` sees the pack once and returns the function that maps
// n observation rows to n action rows.
using Actor = std::function<void(const float* obs, int n, float* actions)>;
using ActorFactory = std::function<Actor(const taskpack::TaskPack&)>;
EvalResult evaluate_actions(const TrainConfig& config, int episodes, uint64_t seed, int threads,
                            const ActorFactory& make_actor, const std::string& split = "train",
                            bool progress = false);

// One task of a meta-RL evaluation: the mean return and success rate of one episode per slot
// before adaptation (the meta-learned policy's deterministic action) and after it.
struct AdaptScore {
  std::string label, task;
  int64_t episodes = 0;
  double return_before = 0, success_before = 0, return_after = 0, success_after = 0;
};

struct MetaEvalResult {
  std::string split;
  int adapt_episodes = 0, adapt_steps = 0;  // adapt_steps 0 where adaptation is in memory
  std::vector<AdaptScore> per_task;  // one per entry of the split (a goal distribution: one)
  double return_before = 0, return_after = 0, success_before = 0, success_after = 0;  // means
  int64_t faults = 0;
};

// Meta-RL's protocol on the `split` (train or test) of a meta run's suite, with `episodes`
// slots per task (per goal of a goal distribution), on the CPU: (1) one episode of the
// meta-learned policy's deterministic action scores "before"; (2) afresh, `adapt_episodes`
// episodes of the sampled policy per slot are what it adapts from, with `adapt_steps` gradient
// steps per task (MAML, ProMP; RL^2 adapts in its memory over these episodes); (3) one episode of
// the adapted policy's deterministic action scores "after". A run whose algorithm does not adapt,
// an unknown split or a suite without it is an Error naming it. `progress`: a progress bar of
// the three phases' finished episodes on stderr.
MetaEvalResult evaluate_meta(LoadedPolicy& policy, const std::string& split, int episodes,
                             int adapt_episodes, int adapt_steps, uint64_t seed, int threads,
                             bool progress = false);

}  // namespace bidex::rl
