// bench/physics_study: the fidelity bars of the physics step (sim/README.md) measured on real
// MuJoCo scenes: a dropped egg's sink, a squeezed egg, a grasp held against gravity for 10 s and
// the distal-middle coupling, for the project's step and for the discrete candidate of the
// physics-step study.
#include "bench/physics_study.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "sim/hand_spec.h"
#include "sim/physics.h"

using namespace bidex;

namespace {

// The bars every adopted step passes (sim/README.md, "Physics settings"): MuJoCo 2.2.2's step
// sank a dropped egg 3.1 mm and a squeezed one 0.05 mm; the coupling stays within 1e-3 rad.
constexpr double kDropBar = 3.1e-3, kSqueezeBar = 0.05e-3, kCouplingBar = 1e-3;

nlohmann::json rest_of(const sim::PhysicsOptions& p) {
  const sim::HandSpec hand = sim::load_hand_spec(sim::default_hand_path());
  return bench::measure_rest(bench::rest_scene(hand, p).build("rest_scene"));
}

// the candidate: discrete, 6 x 1/360 s, contacts and couplings at half the timestep, no REFSAFE
sim::PhysicsOptions discrete6() {
  sim::PhysicsOptions p = sim::load_physics(sim::default_physics_path());
  p.integrator = "discrete";
  p.refsafe = false;
  p.substeps = 6;
  p.timestep = sim::kControlDt / 6;
  p.contact_solref[0] = p.coupling_solref[0] = p.timestep / 2;
  return p;
}

}  // namespace

TEST_CASE("the project's physics step passes the contact and coupling bars", "[bench][physics]") {
  const sim::PhysicsOptions p = sim::load_physics(sim::default_physics_path());
  const auto rest = rest_of(p);
  INFO(rest.dump(2));
  CHECK(rest["finite"].get<bool>());
  CHECK(rest["egg_on_hand"].get<bool>());
  CHECK(rest["drop"]["max_penetration_m"].get<double>() <= kDropBar);
  CHECK(rest["drop"]["egg_on_hand_after_1_5s"].get<bool>());
  CHECK(rest["max_penetration_squeeze_m"].get<double>() <= kSqueezeBar);
  const sim::HandSpec hand = sim::load_hand_spec(sim::default_hand_path());
  const auto c = bench::measure_coupling(sim::two_hand_scene(hand, p).build("two_hand_scene"), hand);
  CHECK(c["max_error_rad"].get<double>() < kCouplingBar);
}

TEST_CASE("the discrete step holds a grasp 10 s against gravity and passes the bars",
          "[bench][physics]") {
  const auto rest = rest_of(discrete6());
  INFO(rest.dump(2));
  const auto& hold = rest["hold"];
  CHECK(hold["finite"].get<bool>());
  CHECK(hold["egg_on_hand_end"].get<bool>());
  CHECK(hold["first_left_hand_s"].get<double>() < 0);  // never left the hand
  CHECK(hold["max_slip_palm_m"].get<double>() < 0.02);
  CHECK(rest["drop"]["max_penetration_m"].get<double>() <= kDropBar);
  CHECK(rest["max_penetration_squeeze_m"].get<double>() <= kSqueezeBar);
}
