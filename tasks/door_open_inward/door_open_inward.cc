// door_open_inward: Door Open Inward (the original's ShadowHandDoorOpenInward);
// defaults in door_open_inward.yaml, decisions in README.md.
#include "tasks/handle_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

// v2: the original code's reward by default (README, "Reward")
BIDEX_DEFINE_HANDLE_TASK(door_open_inward, "Door Open Inward", "ShadowHandDoorOpenInward",
                         HumanAge{13, 13, "13", false},
                         Difficulty::kEasy, "Opens and closes cupboard and oven doors.",
                         /*episode_length=*/250, /*object=*/"door",
                         /*version=*/2)

}  // namespace bidex::tasks
