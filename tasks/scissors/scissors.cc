// scissors: Open Scissors (the original's ShadowHandScissors);
// defaults in scissors.yaml, decisions in README.md.
#include "tasks/registry.h"
#include "tasks/table_family.h"

namespace bidex::tasks {

BIDEX_DEFINE_TABLE_TASK(scissors, TableKind::kScissors, "Open Scissors", "ShadowHandScissors",
                        HumanAge{7, 7, "7", false},
                        "Holds a toy in one hand and works it with the other.",
                        /*episode_length=*/150)

}  // namespace bidex::tasks
