// pen: Open Pen Cap (the original's ShadowHandPen);
// defaults in pen.yaml, decisions in README.md.
#include "tasks/registry.h"
#include "tasks/table_family.h"

namespace bidex::tasks {

// v2: the reach terms on the mean fingertip distance, the paper's one distance a hand (README,
// "Reward")
BIDEX_DEFINE_TABLE_TASK(pen, TableKind::kPen, "Open Pen Cap", "ShadowHandPen",
                        HumanAge{7, 7, "7", false},
                        "Holds a toy in one hand and works it with the other.",
                        /*episode_length=*/125, /*version=*/2)

}  // namespace bidex::tasks
