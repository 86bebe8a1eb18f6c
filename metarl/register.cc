// The meta-RL family's one registration.
#include <mutex>

#include "metarl/algorithms.h"
#include "metarl/config.h"

namespace bidex::metarl {

void register_algorithms() {
  static std::once_flag once;
  std::call_once(once, [] {
    using rl::TrainsOn;
    rl::register_algorithm({"maml", "MAML", TrainsOn::kSuite, "maml", true}, make_maml,
                           [](const YamlView& s) { read_gradient_meta(s, false); });
    rl::register_algorithm({"promp", "ProMP", TrainsOn::kSuite, "promp", true}, make_promp,
                           [](const YamlView& s) { read_gradient_meta(s, true); });
    rl::register_algorithm({"rl2", "RL^2", TrainsOn::kSuite, "rl2", true}, make_rl2,
                           [](const YamlView& s) { read_rl2(s); });
  });
}

}  // namespace bidex::metarl
