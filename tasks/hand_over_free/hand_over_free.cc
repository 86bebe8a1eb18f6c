// hand_over_free: hand_over with free bases, the form the paper's MT4 and ML4 suites use;
// defaults in hand_over_free.yaml, what differs and why in README.md.
#include "tasks/catch_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

const TaskSpec& hand_over_free_spec() {
  static const TaskSpec spec = [] {
    const TaskSpec& base = hand_over_spec();
    TaskSpec s = catch_family_spec("hand_over_free", "Hand Over (free bases)", "", base.age,
                                   base.difficulty, base.skill, base.episode_length,
                                   /*free_base=*/true, /*nobjects=*/1);
    s.variant_of = "hand_over";
    s.hands_collide = true;  // the original's MT4 environment creates its hands with filter 0
    return s;
  }();
  return spec;
}

std::unique_ptr<Task> make_hand_over_free(const std::string& config_file) {
  return make_catch_task(hand_over_free_spec(), config_file);
}

}  // namespace bidex::tasks
