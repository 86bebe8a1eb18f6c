// The algorithm registry: what `bidex train --algo NAME` can run and what each trains on. A
// lookup, never a string comparison in the trainer; adding an algorithm is its own file plus one
// line in algorithms.cc. (The Algorithm interface itself, which needs LibTorch, is algorithm.h.)
#pragma once

#include <string>
#include <vector>

namespace bidex::rl {

// What an algorithm trains on.
enum class TrainsOn { kTask, kSuite };

struct AlgorithmInfo {
  std::string name;   // --algo NAME; its defaults are configs/train/NAME.yaml
  std::string title;  // in plots: "PPO", "multi-task PPO"
  TrainsOn trains_on = TrainsOn::kTask;
  std::string section;  // its settings' section in the YAML ("ppo", "trpo")
};

// Every algorithm `bidex train` knows, in the order --help lists them.
std::vector<AlgorithmInfo> algorithm_registry();
// The entry of `name`; an unknown name is a ConfigError (key `algo`) listing the known ones.
AlgorithmInfo find_algorithm(const std::string& name);
// "ppo, mtppo": the known names, for messages and --help.
std::string algorithm_names();

}  // namespace bidex::rl
