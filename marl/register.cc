// The multi-agent family's one registration.
#include <cctype>
#include <mutex>

#include "marl/algorithms.h"
#include "marl/config.h"

namespace bidex::marl {

void register_algorithms() {
  static std::once_flag once;
  std::call_once(once, [] {
    using rl::TrainsOn;
    for (const char* a : {"ippo", "mappo", "happo", "hatrpo"}) {
      const std::string name = a;
      const auto make = name == "ippo"    ? make_ippo
                        : name == "mappo" ? make_mappo
                        : name == "happo" ? make_happo
                                          : make_hatrpo;
      std::string title = name;
      for (auto& ch : title) ch = static_cast<char>(std::toupper(ch));
      rl::register_algorithm({name, title, TrainsOn::kTask, name, false, true}, make,
                             [name](const YamlView& s) { read_onpolicy(s, name); });
    }
    rl::register_algorithm({"maddpg", "MADDPG", TrainsOn::kTask, "maddpg", false, true},
                           make_maddpg,
                           [](const YamlView& s) { read_maddpg(s); });
  });
}

}  // namespace bidex::marl
