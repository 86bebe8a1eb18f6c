// lift_underarm: Lift Pot / Lift Underarm (the original's ShadowHandLiftUnderarm);
// defaults in lift_underarm.yaml, decisions in README.md.
#include "tasks/handle_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

BIDEX_DEFINE_HANDLE_TASK(lift_underarm, "Lift Pot (Lift Underarm)", "ShadowHandLiftUnderarm",
                         HumanAge{12, 12, "12", false}, Difficulty::kEasy,
                         "Can bring a sippy cup to the mouth to drink.",
                         /*episode_length=*/500, /*object=*/"pot")

}  // namespace bidex::tasks
