// two_catch_underarm: Two Catch Underarm (the original's ShadowHandTwoCatchUnderarm); defaults in two_catch_underarm.yaml, decisions in README.md.
#include "tasks/catch_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

const TaskSpec& two_catch_underarm_spec() {
  static const TaskSpec spec = catch_family_spec(
      "two_catch_underarm", "Two Catch Underarm", "ShadowHandTwoCatchUnderarm", HumanAge{216, 216, "adult", false}, Difficulty::kHard,
      "Some adults can throw two objects between their hands at once, like a juggler.",
      /*episode_length=*/75, /*free_base=*/true, /*nobjects=*/2);
  return spec;
}

std::unique_ptr<Task> make_two_catch_underarm(const std::string& config_file) {
  return make_catch_task(two_catch_underarm_spec(), config_file);
}

}  // namespace bidex::tasks
