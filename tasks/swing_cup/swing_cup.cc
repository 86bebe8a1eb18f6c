// swing_cup: Swing Cup (the original's ShadowHandSwingCup);
// defaults in swing_cup.yaml, decisions in README.md.
#include "tasks/registry.h"
#include "tasks/table_family.h"

namespace bidex::tasks {

BIDEX_DEFINE_TABLE_TASK(swing_cup, TableKind::kSwingCup, "Swing Cup", "ShadowHandSwingCup",
                        HumanAge{11, 11, "11", false},
                        "Turns things with a twist of the hands, like a steering wheel on a toy car.",
                        /*episode_length=*/300)

}  // namespace bidex::tasks
