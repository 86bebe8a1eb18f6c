// switch: Turn Button On/Off (the original's ShadowHandSwitch);
// defaults in switch.yaml, decisions in README.md.
#include "tasks/registry.h"
#include "tasks/table_family.h"

namespace bidex::tasks {

// v2: the press term's zero point is the original's (README, "Reward")
BIDEX_DEFINE_TABLE_TASK(switch, TableKind::kSwitch, "Turn Button On/Off", "ShadowHandSwitch",
                        HumanAge{11, 11, "11", false},
                        "Pushes hard things such as the button of a toy phone.",
                        /*episode_length=*/125, /*version=*/2)

}  // namespace bidex::tasks
