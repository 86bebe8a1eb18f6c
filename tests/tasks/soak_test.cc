// tasks/env under load: 100,352 slot-steps (1,024 slots x 98 control steps) of uniform random
// actions in [-1, 1] per task, with no simulation fault. 98 steps pass the 75-step time limit, so
// every slot also runs a reset inside step and the start of a second episode; 1,024 slots give
// 1,024 + reset samples per task. Slow (about 45 s per task on two idle cores): tagged [soak] and
// labelled `soak` in ctest (tests/CMakeLists.txt), still run by a plain `ctest`.
#include <cmath>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

namespace {

constexpr int kSlots = 1024, kSteps = 98;  // 100,352 slot-steps

void soak(const std::string& id) {
  auto env = make_env(id, kSlots, 2024);
  std::mt19937_64 rng(77);
  std::vector<float> a(static_cast<size_t>(kSlots) * env->act_dim());
  int64_t faults = 0, episodes = 0, bad_values = 0;
  for (int step = 0; step < kSteps; ++step) {
    random_actions(a, rng);
    env->step(a);
    auto st = env->take_stats();
    faults += st.faults;
    episodes += st.episodes;
    for (float r : env->reward) bad_values += !std::isfinite(r);
  }
  INFO(id << ": " << faults << " faults, " << episodes << " episodes finished in "
          << static_cast<int64_t>(kSlots) * kSteps << " slot-steps");
  CHECK(faults == 0);
  CHECK(env->batch().total_faults() == 0);
  CHECK(bad_values == 0);
  for (float x : env->obs) bad_values += !std::isfinite(x);
  CHECK(bad_values == 0);
  CHECK(episodes >= kSlots);  // every slot ended an episode (time limit or task) and went on
}

}  // namespace

TEST_CASE("soak: hand_over: 100k random slot-steps without a fault", "[tasks][soak]") {
  soak("hand_over");
}
TEST_CASE("soak: catch_underarm: 100k random slot-steps without a fault", "[tasks][soak]") {
  soak("catch_underarm");
}
TEST_CASE("soak: catch_over2underarm: 100k random slot-steps without a fault", "[tasks][soak]") {
  soak("catch_over2underarm");
}
TEST_CASE("soak: catch_abreast: 100k random slot-steps without a fault", "[tasks][soak]") {
  soak("catch_abreast");
}
TEST_CASE("soak: two_catch_underarm: 100k random slot-steps without a fault", "[tasks][soak]") {
  soak("two_catch_underarm");
}
