// door_open_outward: Door Open Outward (the original's ShadowHandDoorOpenOutward);
// defaults in door_open_outward.yaml, decisions in README.md.
#include "tasks/handle_family.h"
#include "tasks/registry.h"

namespace bidex::tasks {

// v2: the original code's reward by default (README, "Reward")
BIDEX_DEFINE_HANDLE_TASK(door_open_outward, "Door Open Outward", "ShadowHandDoorOpenOutward",
                         HumanAge{13, 13, "13", false},
                         Difficulty::kEasy, "Opens and closes cupboard and oven doors.",
                         /*episode_length=*/250, /*object=*/"door",
                         /*version=*/2)

}  // namespace bidex::tasks
