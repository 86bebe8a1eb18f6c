// door_close_outward: Door Close Outward (the original's ShadowHandDoorCloseOutward);
// defaults in door_close_outward.yaml, decisions in README.md.
#include "tasks/handle_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

// v2: the original code's reward by default (README, "Reward")
BIDEX_DEFINE_HANDLE_TASK(door_close_outward, "Door Close Outward", "ShadowHandDoorCloseOutward",
                         HumanAge{13, 13, "13", false},
                         Difficulty::kEasy, "Opens and closes cupboard and oven doors.",
                         /*episode_length=*/250, /*object=*/"door",
                         /*version=*/2)

}  // namespace bidex::tasks
