// catch_abreast: Catch Abreast (the original's ShadowHandCatchAbreast);
// defaults in catch_abreast.yaml, decisions in README.md.
#include "tasks/catch_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

BIDEX_DEFINE_CATCH_TASK(catch_abreast, "Catch Abreast", "ShadowHandCatchAbreast",
                        HumanAge{9, 10, "9-10", true}, Difficulty::kEasy,
                        "Passing an object between one person's two hands, side by side (the "
                        "paper's commented-out hand-over row).",
                        /*episode_length=*/150, /*free_base=*/true, /*nobjects=*/1)

}  // namespace bidex::tasks
