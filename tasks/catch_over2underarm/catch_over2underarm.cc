// catch_over2underarm: Catch Over2Underarm (the original's ShadowHandCatchOver2Underarm); defaults in catch_over2underarm.yaml, decisions in README.md.
#include "tasks/catch_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

const TaskSpec& catch_over2underarm_spec() {
  static const TaskSpec spec = catch_family_spec(
      "catch_over2underarm", "Catch Over2Underarm", "ShadowHandCatchOver2Underarm", HumanAge{9, 10, "9-10", true}, Difficulty::kEasy,
      "Passing an object from hand to hand; here thrown from an upright hand to a palm-up hand (the paper's commented-out hand-over row).",
      /*episode_length=*/75, /*free_base=*/true, /*nobjects=*/1);
  return spec;
}

std::unique_ptr<Task> make_catch_over2underarm(const std::string& config_file) {
  return make_catch_task(catch_over2underarm_spec(), config_file);
}

}  // namespace bidex::tasks
