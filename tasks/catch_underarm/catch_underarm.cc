// catch_underarm: Catch Underarm (the original's ShadowHandCatchUnderarm);
// defaults in catch_underarm.yaml, decisions in README.md.
#include "tasks/catch_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

BIDEX_DEFINE_CATCH_TASK(catch_underarm, "Catch Underarm", "ShadowHandCatchUnderarm",
                        HumanAge{48, 48, "48", false}, Difficulty::kHard,
                        "Catches a large ball most of the time.",
                        /*episode_length=*/75, /*free_base=*/true,
                        /*nobjects=*/1)

}  // namespace bidex::tasks
