// The offline family's one registration.
#include <mutex>

#include "offline/algorithms.h"
#include "offline/config.h"

namespace bidex::offline {

YamlView section_of(const rl::TrainConfig& config) {
  return YamlView::load_string(config.section_yaml, config.algo + " section");
}

void register_algorithms() {
  static std::once_flag once;
  std::call_once(once, [] {
    using rl::TrainsOn;
    rl::register_algorithm({"bc", "BC", TrainsOn::kDataset, "bc"}, make_bc,
                           [](const YamlView& s) { read_bc(s); });
    rl::register_algorithm({"bcq", "BCQ", TrainsOn::kDataset, "bcq"}, make_bcq,
                           [](const YamlView& s) { read_bcq(s); });
    rl::register_algorithm({"td3bc", "TD3+BC", TrainsOn::kDataset, "td3bc"}, make_td3bc,
                           [](const YamlView& s) { read_td3bc(s); });
    rl::register_algorithm({"iql", "IQL", TrainsOn::kDataset, "iql"}, make_iql,
                           [](const YamlView& s) { read_iql(s); });
  });
}

}  // namespace bidex::offline
