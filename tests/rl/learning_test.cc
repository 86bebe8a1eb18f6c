// Learning in CI, one test per family: on catch_underarm_raise (a registered reduced
// catch_underarm, see its README), with each algorithm's per-task defaults of
// configs/train/<algo>.yaml (64 slots, 30,720 slot-steps), training must lift the policy's mean
// return well above the random policy's. Each bar sits at less than half of the smallest gain
// measured over seeds 0-3 on two cores (bench/learning_seeds.sh).
#include "tests/rl/rl_fixture.h"

#include "rl/trainer.h"
#include "tasks/env.h"

using namespace bidex;

namespace {
// Mean return of `episodes` random-action episodes, one per slot.
double random_return(int episodes, uint64_t seed) {
  auto env = test::make_env("catch_underarm_raise", episodes, seed);
  env->reset();
  std::mt19937_64 rng(seed);
  std::vector<float> a(size_t(episodes) * env->act_dim());
  std::vector<double> ret(episodes, 0.0);
  std::vector<uint8_t> done(episodes, 0);
  int left = episodes;
  while (left > 0) {
    tasks::random_actions(a, rng);
    env->step(a);
    for (int s = 0; s < episodes; ++s) {
      if (done[s]) continue;
      ret[s] += env->reward[s];
      if (env->terminated[s] || env->truncated[s]) {
        done[s] = 1;
        --left;
      }
    }
  }
  double sum = 0;
  for (double r : ret) sum += r;
  return sum / episodes;
}

// Trains `algo` with seed 1 and checks its policy's mean return over 64 evaluation episodes
// against the random policy's plus `margin`.
void check_learns(const std::string& algo, double margin) {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  const std::string yaml = rl::resolve_train_yaml(rl::default_train_config(algo), algo,
                                                  "catch_underarm_raise", {"seed=1"});
  rl::TrainOptions o;
  o.progress = false;
  const auto r = rl::train_new(yaml, dir, o);
  REQUIRE(r.steps >= 30720);
  rl::LoadedPolicy policy(dir);
  const auto trained = rl::evaluate(policy, 64, 777, 0);
  const double random = random_return(64, 777);
  INFO(algo << ": random " << random << ", trained " << trained.mean_return);
  CHECK(trained.faults == 0);
  CHECK(trained.mean_return > random + margin);
}
}  // namespace

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
