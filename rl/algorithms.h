// The algorithm registry: what `bidex train --algo NAME` can run and what each trains on. A
// lookup, never a string comparison in the trainer; adding an algorithm is its own file plus one
// line in algorithms.cc. (The Algorithm interface itself, which needs LibTorch, is algorithm.h.)
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace bidex {
class YamlView;
}

namespace bidex::rl {

// What an algorithm trains on: what it collects on a task or a suite's train split, or a dataset
// of one task (offline: the pack only evaluates the policy as it learns).
enum class TrainsOn { kTask, kSuite, kDataset };

struct AlgorithmInfo {
  std::string name;   // --algo NAME; its defaults are configs/train/NAME.yaml
  std::string title;  // in plots: "PPO", "multi-task PPO"
  TrainsOn trains_on = TrainsOn::kTask;
  std::string section;  // its settings' section in the YAML ("ppo", "trpo")
  // Adapts to each task at evaluation (meta-RL): bidex eval --split runs its protocol, and it
  // trains on the train split of a suite that has a test split.
  bool meta = false;
  // Acts through agents (marl): its section has `agents`, set by bidex train --agents.
  bool multi_agent = false;
};

// Reads a family's own YAML section strictly (a ConfigError naming the key). rl reads its own
// algorithms' sections in config.cc; a family registered from outside rl (algorithm.h,
// register_algorithm) brings its reader, and its factory reads TrainConfig::section_yaml with it.
using SectionReader = std::function<void(const YamlView& section)>;
// The reader of `name`'s section, or null for rl's own algorithms.
const SectionReader* section_reader(const std::string& name);

// Every algorithm `bidex train` knows, in the order --help lists them.
std::vector<AlgorithmInfo> algorithm_registry();
// The entry of `name`; an unknown name is a ConfigError (key `algo`) listing the known ones.
AlgorithmInfo find_algorithm(const std::string& name);
// "ppo, mtppo": the known names, for messages and --help.
std::string algorithm_names();

}  // namespace bidex::rl
