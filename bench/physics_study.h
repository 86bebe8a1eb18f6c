// The physics study behind configs/sim/physics.yaml and the hand's damping/gain/base numbers:
// sweeps candidate settings of the two-hand scene one factor at a time around the current
// configuration and measures, for each, cost, faults under random actions and the quality of
// contact, coupling, base and joint behaviour. `bidex bench physics` runs it; sim/README.md
// reads its results.
#pragma once

#include <array>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "sim/hand_spec.h"
#include "sim/model.h"
#include "sim/physics.h"
#include "sim/scene.h"

namespace bidex::bench {

// The hand numbers the study varies. "Finger" means every joint but the wrist (WR*), i.e. the
// joints that take configs/hands/shadow.yaml's joint_defaults.
struct HandTuning {
  double finger_damping = 0.1;   // N m s/rad
  double finger_kp = 1.0;        // N m/rad
  double frictionloss = 0.001;   // N m, every hand joint (wrist included)
  double base_translation = 500; // N s/m
  double base_rotation = 10;     // N m s/rad
};

// Reads the tuning from a spec (from joint FF3 and the base).
HandTuning hand_tuning(const sim::HandSpec& spec);
// The spec with the tuning applied to every finger joint and the base; wrist joints keep their
// damping and gain (frictionloss applies to every joint).
sim::HandSpec apply_tuning(sim::HandSpec spec, const HandTuning& t);

// One measurement set: a scene built with `physics` and `hand`.
struct Candidate {
  std::string group;  // which sweep it belongs to ("reference" for the starting point)
  std::string name;   // short label, e.g. "substeps=8"
  sim::PhysicsOptions physics;
  HandTuning hand;
  bool cost_only = false;  // only the cost is measured (the reference's repeat)
};

// The candidates of every sweep around `physics` and `hand`: the reference first (twice: the
// repeat's cost ratio shows the timing noise), then each sweep, leaving out values that MuJoCo
// would make equal to a candidate already listed (REFSAFE raises time constants to 2 dt).
// `groups` picks sweeps by name (empty: all of timestep, solver, contact, coupling, damping,
// frictionloss, kp, base; "reference" alone: the reference only).
std::vector<Candidate> study_candidates(const sim::PhysicsOptions& physics, const HandTuning& hand,
                                        const std::vector<std::string>& groups = {});

// --- single measurements on one slot of a scene (usable from tests) -----------------------------
// All run from the scene's initial state, step MuJoCo at the physics rate (so maxima see every
// physics step) and change control targets at the control rate (60 Hz) as a policy would.

// The scene of the rest test: the two-hand layout on fixed bases (so contact alone is measured)
// and the egg lying along the right hand's fingers, just above the palm.
sim::SceneBuilder rest_scene(const sim::HandSpec& right, const sim::PhysicsOptions& physics);

// On rest_scene: the egg settles on the right palm (1 s), rests with the hand still (2 s: its
// drift in the world and relative to the palm, penetration = max over egg contacts of -dist),
// then the four fingers close on it with full force (1 s: penetration while squeezed). Then,
// from a fresh start, the egg dropped from 20 cm onto the palm (a catch in miniature):
// penetration at impact, rebound, whether it stays on the hand.
nlohmann::json measure_rest(const sim::SimModel& rest_model);

// The four middle joints (X2) of both hands swept 0 -> 90 deg over 1 s (then held 0.5 s); the
// largest coupling error |q_X1 - ratio q_X2| seen, per hand and overall (rad), and how far each
// hand's middle joints got.
nlohmann::json measure_coupling(const sim::SimModel& model, const sim::HandSpec& spec);

// The left (empty) hand's free base: with zero wrench (drift over 2 s), under a constant force
// (steady speed, and the rotation it induces) and a constant torque (steady angular speed).
// The right hand, onto which the egg falls, is reported for the zero-wrench case too.
nlohmann::json measure_hang(const sim::SimModel& model, double force, double torque);

// The original's free base: no joints, but PhysX's damping of `damping` (1/s) on the linear and
// angular velocity of every hand link, applied once per `substep` as v <- (v + a dt) max(0,
// 1 - c dt). Under a steady force or torque the whole hand then moves like one body whose
// speed settles where the damping takes back what the push adds each substep, as a damper of
// m (1 - k) / (dt k) would hold it (k = 1 - c dt); likewise per axis of rotation with the
// hand's inertia about its centre of mass. Mass and inertia are this model's (which follow the
// original's link masses), at the scene's initial pose.
struct PhysxDampedResponse {
  double mass = 0;                          // kg, every body of the hand
  std::array<double, 3> inertia{};          // kg m^2 about the centre of mass, world x, y, z
  double linear_damping = 0;                // N s/m that gives the same steady speed
  std::array<double, 3> angular_damping{};  // N m s/rad per world axis, likewise
};
PhysxDampedResponse physx_damped_response(const sim::SimModel& model, const sim::HandIndex& hand,
                                          double damping = 100.0, double substep = 1.0 / 120.0);

// Step responses of FF3 and FF2 (left hand) to a target step of `step_rad`: rise time (10-90%),
// overshoot, 2% settling time, error after 1 s.
nlohmann::json measure_step(const sim::SimModel& model, double step_rad = 0.5);

struct StudySoak {
  int slots = 32;
  int64_t slot_steps = 6000;
  double max_force = 83.3;
  double max_torque = 8.33;
  int episode_steps = 75;  // each slot is reset this often (staggered), so the egg starts on the
                           // palm again; 0: never
  uint64_t seed = 1;
};

struct CostRun {
  int slots = 16;
  int steps = 12;   // control steps per round
  int rounds = 5;   // identical rounds (same seed); the fastest is kept
  double max_force = 83.3;
  double max_torque = 8.33;
  uint64_t seed = 3;
};

// Cost on one thread: slot-steps/s and physics steps/s of sim::step under random actions, from
// the thread's CPU time, the best of `rounds` identical runs (a shared machine only ever slows a
// run down). With `reference`, its rounds alternate with the model's and the speed ratio of the
// two, measured in the same window, is given too.
nlohmann::json measure_cost(const sim::SimModel& model, const CostRun& run = {},
                            const sim::SimModel* reference = nullptr);

// Random-action slot-steps on one thread (sim::step, new random inputs every control step):
// faults by kind, largest MuJoCo memory use, solver iterations, penetration by kind of contact
// (object-hand, object-world, hand-hand, ...) and coupling error at the ends of control steps.
// `tick` gets the slot-steps done.
nlohmann::json measure_soak(const sim::SimModel& model, const sim::HandSpec& spec,
                            const StudySoak& soak,
                            const std::function<void(int64_t)>& tick = nullptr);

// --- the whole study -----------------------------------------------------------------------------

struct PhysicsStudyConfig {
  sim::PhysicsOptions physics;  // the reference (configs/sim/physics.yaml)
  std::string hand_path;        // the reference hand (configs/hands/shadow.yaml when empty)
  std::vector<std::string> groups;  // sweeps to run (empty: all)
  StudySoak soak{32, 3200, 83.3, 8.33, 75, 1};   // at catch_underarm's limits
  StudySoak hard{32, 1600, 833.0, 33.3, 75, 2};  // at the hardest task's limits (0 steps: skip)
  CostRun cost;                     // 0 rounds: skip
  int memory_slots = 8192;          // the slot count memory figures are given for
  bool progress = true;
};

nlohmann::json run_physics_study(const PhysicsStudyConfig& cfg);

// PhysicsOptions as JSON (every field).
nlohmann::json physics_json(const sim::PhysicsOptions& p);

}  // namespace bidex::bench
