// hand_over: Hand Over (the original's ShadowHandOver); defaults in
// hand_over.yaml, decisions in README.md.
#include "tasks/catch_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

BIDEX_DEFINE_CATCH_TASK(hand_over, "Hand Over", "ShadowHandOver", HumanAge{9, 10, "9-10", true},
                        Difficulty::kEasy,
                        "A child passes a ring from one hand to the other (the "
                        "paper's commented-out table row; easy there too).",
                        /*episode_length=*/75, /*free_base=*/false,
                        /*nobjects=*/1)

}  // namespace bidex::tasks
