// Task throughput: slot-steps/s of whole task steps (actions -> physics -> rewards, resets ->
// observations), with random actions, at each slot count; and a profile of where the time goes
// (task stages against physics, and MuJoCo's own stage timers inside physics).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace bidex::bench {

struct TaskBenchConfig {
  std::vector<std::string> tasks;       // task ids
  std::vector<int> slots{2048, 8192};
  int threads = 0;                      // 0: all cores
  double min_seconds = 3;               // timed stepping per measurement (after warm-up)
  int warmup_steps = 5;
  bool profile = true;                  // a second, profiled run per measurement
  uint64_t seed = 1;
  std::string physics_file;             // empty: default
  std::string task_config;              // one task only: its YAML (empty: the task's default)
  bool progress = true;
};

nlohmann::json run_task_bench(const TaskBenchConfig& cfg);

}  // namespace bidex::bench
