// catch_over2underarm: Catch Over2Underarm (the original's
// ShadowHandCatchOver2Underarm); defaults in catch_over2underarm.yaml,
// decisions in README.md.
#include "tasks/catch_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

BIDEX_DEFINE_CATCH_TASK(catch_over2underarm, "Catch Over2Underarm", "ShadowHandCatchOver2Underarm",
                        HumanAge{9, 10, "9-10", true}, Difficulty::kEasy,
                        "Passing an object from hand to hand; here thrown from an upright hand to "
                        "a palm-up hand (the paper's commented-out hand-over row).",
                        /*episode_length=*/75, /*free_base=*/true, /*nobjects=*/1)

}  // namespace bidex::tasks
