// catch_underarm: Catch Underarm (the original's ShadowHandCatchUnderarm); defaults in catch_underarm.yaml, decisions in README.md.
#include "tasks/catch_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

const TaskSpec& catch_underarm_spec() {
  static const TaskSpec spec = catch_family_spec(
      "catch_underarm", "Catch Underarm", "ShadowHandCatchUnderarm", HumanAge{48, 48, "48", false}, Difficulty::kHard,
      "Catches a large ball most of the time.",
      /*episode_length=*/75, /*free_base=*/true, /*nobjects=*/1);
  return spec;
}

std::unique_ptr<Task> make_catch_underarm(const std::string& config_file) {
  return make_catch_task(catch_underarm_spec(), config_file);
}

}  // namespace bidex::tasks
