// bidex collect: datasets of a task at a chosen quality, written by the policy of a run's
// checkpoint (or a random one) stepping a pack of the task (offline/recorder.h), with the
// reference scores that normalise offline results: the random policy's mean return (0) and the
// expert's, online PPO's newest checkpoint, deterministic (100).
#pragma once

#include <cstdint>
#include <string>

#include "offline/dataset.h"

namespace bidex::offline {

struct CollectOptions {
  std::string quality;           // random, medium or expert (replay: bidex train --record-replay;
                                 // medium-expert: merge())
  std::string task;              // random: the task; with a run: its task (must match if given)
  std::string run_dir;           // the acting policy's run (medium, expert)
  std::string checkpoint;        // its checkpoint; empty: the newest (expert), or for medium the
                                 // one nearest half the newest's return (medium_checkpoint)
  std::string expert_run;        // the run whose newest checkpoint scores 100; empty: run_dir
  std::string out;               // the new dataset's folder
  int64_t steps = 1000000;       // transitions, rounded up to whole episodes
  int slots = 256;               // parallel slots of the pack
  uint64_t seed = 0;
  int threads = 0;               // CPU simulation threads, 0: all cores
  std::string device = "auto";   // where the pack steps: cpu, cuda or auto
  int ref_episodes = 128;        // episodes of each reference evaluation (CPU)
  bool sample = true;            // the policy's sampled actions (false: its mean)
  bool progress = true;
  std::string command;           // recorded in metadata.json
};

DatasetInfo collect(const CollectOptions& options);

// The checkpoint of `run_dir` whose training return (metrics.csv, the mean over the 10 updates up
// to it) is nearest half that of the newest checkpoint: the original's "medium" policy.
std::string medium_checkpoint(const std::string& run_dir);

}  // namespace bidex::offline
