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


TEST_CASE("soak: hand_over: 100k random slot-steps without a fault", "[tasks][soak]") {
  soak_task("hand_over");
}
TEST_CASE("soak: catch_underarm: 100k random slot-steps without a fault", "[tasks][soak]") {
  soak_task("catch_underarm");
}
TEST_CASE("soak: catch_over2underarm: 100k random slot-steps without a fault", "[tasks][soak]") {
  soak_task("catch_over2underarm");
}
TEST_CASE("soak: catch_abreast: 100k random slot-steps without a fault", "[tasks][soak]") {
  soak_task("catch_abreast");
}
TEST_CASE("soak: two_catch_underarm: 100k random slot-steps without a fault", "[tasks][soak]") {
  soak_task("two_catch_underarm");
}
