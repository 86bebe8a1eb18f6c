// catch_underarm_raise: a reduced variant of catch_underarm that PPO learns within a CI test's
// minutes; defaults in catch_underarm_raise.yaml, what differs and why in README.md.
#include "tasks/catch_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

const TaskSpec& catch_underarm_raise_spec() {
  static const TaskSpec spec = [] {
    TaskSpec s = catch_family_spec("catch_underarm_raise", "Catch Underarm (raise variant)", "",
                                   HumanAge{48, 48, "48", false}, Difficulty::kEasy,
                                   "Raises an object held in the palm (a reduced catch_underarm).",
                                   /*episode_length=*/40, /*free_base=*/true, /*nobjects=*/1);
    s.variant_of = "catch_underarm";
    return s;
  }();
  return spec;
}

std::unique_ptr<Task> make_catch_underarm_raise(const std::string& config_file) {
  return make_catch_task(catch_underarm_raise_spec(), config_file);
}

}  // namespace bidex::tasks
