// two_catch_underarm: Two Catch Underarm (the original's
// ShadowHandTwoCatchUnderarm); defaults in two_catch_underarm.yaml, decisions
// in README.md.
#include "tasks/catch_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

BIDEX_DEFINE_CATCH_TASK(two_catch_underarm, "Two Catch Underarm", "ShadowHandTwoCatchUnderarm",
                        HumanAge{216, 216, "adult", false}, Difficulty::kHard,
                        "Some adults can throw two objects between their hands "
                        "at once, like a juggler.",
                        /*episode_length=*/75, /*free_base=*/true,
                        /*nobjects=*/2)

}  // namespace bidex::tasks
