// hand_over: Hand Over (the original's ShadowHandOver); defaults in hand_over.yaml, decisions in README.md.
#include "tasks/catch_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

const TaskSpec& hand_over_spec() {
  static const TaskSpec spec = catch_family_spec(
      "hand_over", "Hand Over", "ShadowHandOver", HumanAge{9, 10, "9-10", true}, Difficulty::kEasy,
      "A child passes a ring from one hand to the other (the paper's commented-out table row; easy there too).",
      /*episode_length=*/75, /*free_base=*/false, /*nobjects=*/1);
  return spec;
}

std::unique_ptr<Task> make_hand_over(const std::string& config_file) {
  return make_catch_task(hand_over_spec(), config_file);
}

}  // namespace bidex::tasks
