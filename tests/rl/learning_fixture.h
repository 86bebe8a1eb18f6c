// The CI learning tests' check (tests/rl/learning_test.cc, tests/marl/learning_test.cc): train
// an algorithm with its per-task defaults for catch_underarm_raise (configs/train/<algo>.yaml)
// and compare its policy's mean return with the random policy's.
#pragma once

#include "tests/rl/rl_fixture.h"

#include <random>

#include "rl/trainer.h"
#include "tasks/env.h"

namespace bidex::test {

// Mean return of `episodes` random-action episodes, one per slot.
inline double random_return(int episodes, uint64_t seed) {
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

// Trains `algo` with seed 1 (then the overrides `extra`) and checks its policy's mean return over
// 64 evaluation episodes against the random policy's plus `margin`.
inline void check_learns(const std::string& algo, double margin,
                         const std::vector<std::string>& extra = {}) {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  std::vector<std::string> overrides = {"seed=1"};
  overrides.insert(overrides.end(), extra.begin(), extra.end());
  const std::string yaml = rl::resolve_train_yaml(rl::default_train_config(algo), algo,
                                                  "catch_underarm_raise", overrides);
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

}  // namespace bidex::test
