// CPU against GPU on the same tasks: episodes of a uniformly random policy on TaskEnv (MuJoCo 3,
// float64) and on WarpTaskEnv (MuJoCo Warp, float32); per task the mean return, episode length
// and success rate of each with their standard errors, and whether they agree within the stated
// tolerance: |difference| <= 4 standard errors of the difference + 2% of the CPU's mean (return,
// length) or + 0.01 (success rate).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace bidex::bench {

struct AgreeBenchConfig {
  std::vector<std::string> tasks;
  int episodes = 1000;       // at least this many finished episodes per side
  int slots = 1024;          // slots (CPU) and worlds (GPU)
  int threads = 0;           // CPU threads (0: all cores)
  std::string device = "cuda";
  uint64_t seed = 1;
};

nlohmann::json run_agree_bench(const AgreeBenchConfig& cfg);

}  // namespace bidex::bench
