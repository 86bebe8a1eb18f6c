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

// Features the two-hand scene does not use: springs, a limited ball joint, a welded body, fixed
// tendons (spring, damper, friction, limits, an equality between two tendons, an actuator),
// a polynomial joint coupling, affine gain and bias, a velocity servo, a motor with gear.
const char* kFeatures = R"(
<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.002"><flag contact="disable"/></option>
  <worldbody>
    <body name="base" pos="0 0 1">
      <joint name="s0" type="slide" axis="1 0 0" range="-0.1 0.1" limited="true" damping="1"/>
      <geom type="box" size="0.1 0.05 0.05" mass="1"/>
      <body name="arm" pos="0.1 0 0">
        <joint name="h1" axis="0 1 0" stiffness="2" springref="0.3" damping="0.1"
               armature="0.01" range="-1 1" limited="true" frictionloss="0.05"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.2"/>
        <body name="welded" pos="0.2 0 0" quat="0.9 0.1 0.3 0">
          <geom type="sphere" size="0.03" mass="0.1" pos="0.01 0 0"/>
          <site name="tip" pos="0.02 0.01 0" quat="0.7 0 0.7 0"/>
          <body name="wrist" pos="0.05 0 0">
            <joint name="b2" type="ball" range="0 0.5" limited="true" damping="0.05"
                   stiffness="0.5"/>
            <geom type="box" size="0.03 0.02 0.01" pos="0.03 0 0" mass="0.05"/>
            <body name="f1" pos="0.06 0 0">
              <joint name="h3" axis="0 0 1" range="-0.5 1.2" limited="true" damping="0.02"/>
              <geom type="capsule" fromto="0 0 0 0.05 0 0" size="0.01" mass="0.02"/>
              <body name="f2" pos="0.05 0 0">
                <joint name="h4" axis="0 0 1" range="0 1.5" limited="true" damping="0.02"/>
                <geom type="capsule" fromto="0 0 0 0.04 0 0" size="0.008" mass="0.01"/>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
    <body name="egg" pos="0.5 0.5 1">
      <freejoint/>
      <geom type="ellipsoid" size="0.03 0.04 0.05" mass="0.1"/>
    </body>
  </worldbody>
  <tendon>
    <fixed name="t1" limited="true" range="-0.3 0.6" frictionloss="0.02" stiffness="1"
           damping="0.1" springlength="0.1">
      <joint joint="h3" coef="1"/>
      <joint joint="h4" coef="0.5"/>
    </fixed>
    <fixed name="t2"><joint joint="h1" coef="1"/></fixed>
  </tendon>
  <equality>
    <joint joint1="h4" joint2="h3" polycoef="0.1 0.8 0.2 0.1 0" solref="0.01 1"/>
    <tendon tendon1="t1" tendon2="t2" polycoef="0 0.5 0 0 0"/>
  </equality>
  <actuator>
    <position joint="s0" kp="50" ctrlrange="-0.1 0.1" forcerange="-5 5" forcelimited="true"
              ctrllimited="true"/>
    <motor joint="h1" gear="2" ctrlrange="-1 1" ctrllimited="true"/>
    <motor tendon="t1" ctrlrange="-1 1" ctrllimited="true"/>
    <general joint="h3" gaintype="affine" gainprm="1 0.5 0.1" biastype="affine"
             biasprm="0 -2 -0.1"/>
    <velocity joint="h4" kv="0.1"/>
  </actuator>
</mujoco>)";

const Scene& features() {
  static const Scene s(bidex::sim::compile_mjcf(kFeatures, "gpu_features"));
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
