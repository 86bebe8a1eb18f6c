// pour_water: Pour Water (the original's ShadowHandKettle);
// defaults in pour_water.yaml, decisions in README.md.
#include "tasks/registry.h"
#include "tasks/table_family.h"

namespace bidex::tasks {

// v2: bidex's reward, a lift term and a steeper pour term (README, "Reward")
BIDEX_DEFINE_TABLE_TASK(pour_water, TableKind::kPourWater, "Pour Water", "ShadowHandKettle",
                        HumanAge{48, 48, "48", false},
                        "Pours water or serves food, with an adult watching.",
                        /*episode_length=*/125, /*version=*/2)

}  // namespace bidex::tasks
