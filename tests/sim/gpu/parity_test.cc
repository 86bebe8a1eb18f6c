// sim/gpu: the GPU engine's stage functions, run on the host, against MuJoCo 2.2.2's own
// functions at random states of the two-hand scene (contacts disabled).
#include "sim/gpu/parity.h"

#include <memory>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "sim/gpu/engine.h"
#include "sim/model.h"
#include "tests/fixture.h"

using namespace bidex::sim::gpu;

namespace {

struct Scene {
  explicit Scene(mjModel* model) : m(model), arrays(model) {}
  ~Scene() { mj_deleteModel(m); }
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;
  mjModel* m;
  ModelArrays arrays;
};

// the two-hand scene without contacts, and the engine's tables for it, built once
const Scene& two_hands() {
  static const Scene s(contact_free_copy(bidex::test::two_hand_model().mj()));
  return s;
}

void require_pass(const ParityReport& r) {
  INFO(r.table());
  CHECK(r.failures() == "");
  REQUIRE(r.pass());
}

}  // namespace

TEST_CASE("every stage of forward matches MuJoCo at random states (float64)", "[sim][gpu]") {
  const Scene& s = two_hands();
  HostEngine<double> engine(s.arrays, 6);
  require_pass(check_forward(s.m, s.arrays, engine, 11, false));
}

TEST_CASE("one Euler step with implicit damping matches mj_step (float64)", "[sim][gpu]") {
  const Scene& s = two_hands();
  HostEngine<double> engine(s.arrays, 6);
  require_pass(check_step(s.m, s.arrays, engine, 12, false));
}

TEST_CASE("a 1 s trajectory under random position targets stays on mj_step's (float64)",
          "[sim][gpu]") {
  const Scene& s = two_hands();
  HostEngine<double> engine(s.arrays, 3);
  const auto& gravcomp = bidex::test::two_hand_model().gravity_compensation();
  require_pass(check_trajectory(s.m, s.arrays, engine, 13, false, 1.0, 8, gravcomp));
}

TEST_CASE("the float32 engine stays within float32 tolerances", "[sim][gpu]") {
  const Scene& s = two_hands();
  HostEngine<float> engine(s.arrays, 4);
  require_pass(check_forward(s.m, s.arrays, engine, 14, true));
  require_pass(check_step(s.m, s.arrays, engine, 15, true));
  const auto& gravcomp = bidex::test::two_hand_model().gravity_compensation();
  require_pass(check_trajectory(s.m, s.arrays, engine, 16, true, 1.0, 8, gravcomp));
}

namespace {

const Scene& features() {
  static const Scene s(bidex::sim::compile_mjcf(features_mjcf(), "gpu_features"));
  return s;
}

}  // namespace

TEST_CASE("tendons, springs, ball limits and other features match MuJoCo too", "[sim][gpu]") {
  const Scene& s = features();
  HostEngine<double> engine(s.arrays, 8);
  require_pass(check_forward(s.m, s.arrays, engine, 21, false));
  require_pass(check_step(s.m, s.arrays, engine, 22, false));
  require_pass(check_trajectory(s.m, s.arrays, engine, 23, false, 1.0, 5, {}));
}

TEST_CASE("the stages split over 4 and 32 lanes per world (the kernels' lane logic) still match",
          "[sim][gpu]") {
  // host threads meeting at barriers stand in for the lanes of a GPU world group
  const Scene& s = two_hands();
  for (int lanes : {4, 32}) {
    INFO(lanes << " lanes");
    HostEngine<double> engine(s.arrays, 2, lanes);
    require_pass(check_forward(s.m, s.arrays, engine, 31, false));
    require_pass(check_step(s.m, s.arrays, engine, 32, false));
    HostEngine<double> tendons(features().arrays, 2, lanes);
    require_pass(check_forward(features().m, features().arrays, tendons, 33, false));
  }
}
