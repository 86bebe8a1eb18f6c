// The algorithm registry: one line per algorithm.
#include "rl/algorithms.h"

#include <stdexcept>

#include "core/error.h"
#include "rl/algorithm.h"
#include "rl/ppo.h"
#include "rl/sac.h"
#include "rl/td3.h"
#include "rl/trpo.h"

namespace bidex::rl {

namespace {

struct Entry {
  AlgorithmInfo info;
  AlgorithmFactory make;
  SectionReader read;  // empty: rl's own (config.cc)
};

std::vector<Entry>& entries() {
  static std::vector<Entry> all = {
      {{"ppo", "PPO", TrainsOn::kTask, "ppo"}, make_ppo, {}},
      // multi-task PPO: PPO on a multi-task suite's pack (one-hot task ids in the observation)
      {{"mtppo", "multi-task PPO", TrainsOn::kSuite, "ppo"}, make_ppo, {}},
      {{"trpo", "TRPO", TrainsOn::kTask, "trpo"}, make_trpo, {}},
      // multi-task TRPO: TRPO on a multi-task suite's pack
      {{"mttrpo", "multi-task TRPO", TrainsOn::kSuite, "trpo"}, make_trpo, {}},
      {{"sac", "SAC", TrainsOn::kTask, "sac"}, make_sac, {}},
      // multi-task SAC: one temperature per task of the suite, from the one-hot task id
      {{"mtsac", "multi-task SAC", TrainsOn::kSuite, "sac"}, make_mtsac, {}},
      {{"td3", "TD3", TrainsOn::kTask, "td3"}, make_td3, {}},
      {{"ddpg", "DDPG", TrainsOn::kTask, "ddpg"}, make_td3, {}},
  };
  return all;
}

const Entry& entry(const std::string& name) {
  for (auto& e : entries())
    if (e.info.name == name) return e;
  throw ConfigError("", "algo", "a known algorithm (" + algorithm_names() + ")", "'" + name + "'");
}

}  // namespace

std::vector<AlgorithmInfo> algorithm_registry() {
  std::vector<AlgorithmInfo> out;
  for (auto& e : entries()) out.push_back(e.info);
  return out;
}

std::string algorithm_names() {
  std::string s;
  for (auto& e : entries()) s += (s.empty() ? "" : ", ") + e.info.name;
  return s;
}

AlgorithmInfo find_algorithm(const std::string& name) { return entry(name).info; }

const SectionReader* section_reader(const std::string& name) {
  const Entry& e = entry(name);
  return e.read ? &e.read : nullptr;
}

void register_algorithm(const AlgorithmInfo& info, AlgorithmFactory make, SectionReader read) {
  for (auto& e : entries())
    if (e.info.name == info.name)
      throw std::logic_error("algorithm " + info.name + " is registered twice");
  entries().push_back({info, std::move(make), std::move(read)});
}

std::unique_ptr<Algorithm> make_algorithm(const std::string& name, const TrainConfig& config,
                                          int64_t obs_dim, int64_t act_dim, int64_t nslot,
                                          const torch::Device& device) {
  TrainConfig settled = config;  // `auto` settings decided for this device (rl/config.h)
  settle_auto(settled, device.is_cuda());
  return entry(name).make(settled, obs_dim, act_dim, nslot, device);
}

}  // namespace bidex::rl
