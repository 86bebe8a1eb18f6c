// Learning in CI, one test per family: on catch_underarm_raise (a registered reduced
// catch_underarm, see its README), with each algorithm's per-task defaults of
// configs/train/<algo>.yaml (64 slots, 30,720 slot-steps), training must lift the policy's mean
// return well above the random policy's. Each bar sits at less than half of the smallest gain
// measured over seeds 0-3 on two cores (bench/learning_seeds.sh).
#include "tests/rl/learning_fixture.h"

using bidex::test::check_learns;

// on-policy: random 12.5, trained 20.5-22.5 (bench/results/learning-ci-2core-mujoco3.json)
TEST_CASE("PPO learns catch_underarm_raise within its CI budget", "[rl][learning]") {
  check_learns("ppo", 3.0);
}

// off-policy, maximum entropy: random 12.2, trained 17.1-21.8 in about 30 s
// (bench/results/learning-sac-2core.json)
TEST_CASE("SAC learns catch_underarm_raise within its CI budget", "[rl][learning][sac]") {
  check_learns("sac", 2.0);
}

// off-policy, deterministic actor, with the pre-tanh penalty of their per-task defaults: random
// 12.2, TD3 16.0-17.7 and DDPG 15.7-19.1 over seeds 0-3 in about 23 s each (gains of 3.5 and
// more: bench/results/learning-td3-2core.json, learning-ddpg-2core.json)
TEST_CASE("TD3 learns catch_underarm_raise within its CI budget", "[rl][learning][td3]") {
  check_learns("td3", 1.5);
}

TEST_CASE("DDPG learns catch_underarm_raise within its CI budget", "[rl][learning][td3]") {
  check_learns("ddpg", 1.5);
}
