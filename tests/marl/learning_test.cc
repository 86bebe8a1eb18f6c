// Learning in CI, the multi-agent family: per-hand agents on catch_underarm_raise with each
// algorithm's per-task defaults of configs/train/<algo>.yaml (64 slots, 30,720 slot-steps) must
// lift the policy's mean return above the random policy's. The bars sit at less than half of the
// smallest gain measured over seeds 0-3 on two cores (bench/results/learning-marl-2core.json).
#include "tests/rl/learning_fixture.h"

#include "marl/algorithms.h"

using bidex::test::check_learns;

TEST_CASE("MAPPO learns catch_underarm_raise within its CI budget", "[marl][learning]") {
  bidex::marl::register_algorithms();
  check_learns("mappo", 2.0);
}

TEST_CASE("HAPPO learns catch_underarm_raise within its CI budget", "[marl][learning]") {
  bidex::marl::register_algorithms();
  check_learns("happo", 2.0);
}
