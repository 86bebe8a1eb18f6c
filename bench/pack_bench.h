// Packed throughput: slot-steps/s of a suite's pack (every task of its train split in one batched
// instance) against each of its tasks alone at the same slot count, measured in one run with
// random actions, on the CPU (one parallel loop over all slots) or the GPU (a MuJoCo Warp backend
// per scene topology, stepped concurrently on streams; actions drawn on the device; the pack is
// also measured with one backend per scene). The target: packed >= 0.8 x the mean single-task
// rate.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace bidex::bench {

struct PackBenchConfig {
  std::string suite = "MT20";   // suite id or file (its train split)
  int slots = 2048;             // the pack's slots in all, and each single task's
  int threads = 0;              // 0: all cores
  double min_seconds = 3;       // timed stepping per measurement (after warm-up)
  int warmup_steps = 5;
  int rounds = 2;               // packed, singles, packed, singles...: the best of each kept
  uint64_t seed = 1;
  std::string device = "cpu";   // cpu (TaskPack), or cuda (WarpPack: a backend per topology)
  bool progress = true;
};

nlohmann::json run_pack_bench(const PackBenchConfig& cfg);

}  // namespace bidex::bench
