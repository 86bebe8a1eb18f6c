// GPU backend throughput: bidex's control step on MuJoCo Warp (base forces at the pivots, the
// per-world fault check, the reset and position passes) against raw MuJoCo Warp (the same
// substeps of mjw.step alone) on the same scene, world count and inputs, in one run; random
// inputs written on the device before every step of both.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace bidex::bench {

struct WarpBenchConfig {
  std::vector<std::string> tasks;          // task ids: each one's scene
  std::vector<int> worlds{2048, 8192, 16384};
  std::string device = "cuda";             // a Warp device ("cpu": plumbing only, slow)
  double min_seconds = 2;                  // timed stepping per measurement (after warm-up)
  int rounds = 2;                          // alternations of raw and bidex; the best of each kept
  int warmup_steps = 10;
  int njmax = 0, nconmax = 0;              // room per world (0: the scene's physics)
  double max_force = 20, max_torque = 2;   // random base inputs (free bases)
  uint64_t seed = 1;
  bool stages = true;                      // also the whole task step where its stages run
  int determinism_steps = 50;              // per task: two fresh backends compared (0: skip)
  int64_t min_checked = 0;                 // fault-checked slot-steps per measurement at least:
                                           // untimed steps after the timed rounds make up the rest
  int phase_steps = 0;                     // > 0: after that many control steps, each part of
                                           // a substep timed (collision, solver, ...)
  std::string physics_file;                // empty: default
  bool progress = true;
};

nlohmann::json run_warp_bench(const WarpBenchConfig& cfg);

}  // namespace bidex::bench
