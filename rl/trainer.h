// The training workflow of `bidex train --algo ppo`, `bidex eval` and `bidex render --run`: a
// run folder holding the resolved config (config.yaml), run.json, metrics (CSV and JSONL), a
// learning curve (SVG) redrawn while training, and checkpoints written atomically every
// save_interval updates, at the end and on SIGINT/SIGTERM. A run resumes from its newest
// checkpoint.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rl/config.h"

namespace bidex::rl {

struct TrainOptions {
  bool progress = true;           // the progress bar on stderr
  int64_t stop_after_updates = 0; // > 0: stop as Ctrl-C would after this many updates in total
  double time_limit_s = 0;        // > 0: stop as Ctrl-C would once this session trained this long
  std::string command;            // recorded in run.json
};

struct TrainResult {
  std::string run_dir;
  int64_t updates = 0, steps = 0;
  bool interrupted = false;       // stopped by a signal or stop_after_updates
  double last_return = 0;         // mean return of the episodes of the last updates (NaN: none)
  double last_success = 0;
  std::string checkpoint;         // the newest checkpoint written
};

// Starts a new run in `run_dir` (created; an existing non-empty folder is an error, nothing in it
// is touched) from a resolved YAML (resolve_train_yaml).
TrainResult train_new(const std::string& resolved_yaml, const std::string& run_dir,
                      const TrainOptions& options);

// Continues the run in `run_dir` from its newest checkpoint, up to its configured steps.
TrainResult train_resume(const std::string& run_dir, const TrainOptions& options);

// The default folder of a new run: runs/<task>-<algo>-<YYYYmmdd-HHMMSS>-s<seed>.
std::string default_run_dir(const TrainConfig& c);

// A trained policy loaded from a run folder (its config.yaml and a checkpoint, default the
// newest), acting deterministically (the Gaussian's mean), on the CPU.
class LoadedPolicy {
 public:
  LoadedPolicy(const std::string& run_dir, const std::string& checkpoint = "");
  ~LoadedPolicy();
  const TrainConfig& config() const;
  const std::string& checkpoint() const;
  int64_t obs_dim() const;
  int64_t act_dim() const;
  int64_t update() const;
  // n rows of obs_dim observations -> n rows of act_dim actions (the mean, clipped to [-1, 1]).
  void act(const float* obs, int n, float* actions);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct EvalResult {
  int episodes = 0;
  double mean_return = 0, std_return = 0, mean_length = 0, success_rate = 0;
  int64_t faults = 0;
};

// Runs `episodes` slots for one episode each with the policy's mean action.
EvalResult evaluate(LoadedPolicy& policy, int episodes, uint64_t seed, int threads);

}  // namespace bidex::rl
