// Parity of the GPU engine with MuJoCo 2.2.2, stage by stage, on any Engine (the host engine in
// CI, the CUDA engine on the GPU machine). Every check puts a different random state in each
// world, runs MuJoCo's own functions on one mjData per world and the engine on all worlds at
// once, and compares field by field:
//   |engine - mujoco| <= atol + rtol |mujoco| + of_max * max|mujoco over the field|
// Constraint rows are compared in MuJoCo's row order (type and id exactly, Jacobians as dense
// rows); the trajectory check steps both for a simulated time under random position targets.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sim/gpu/engine.h"
#include "sim/gpu/model.h"

struct mjModel_;
typedef struct mjModel_ mjModel;

namespace bidex::sim::gpu {

struct Tolerance {
  double atol = 0;    // absolute
  double rtol = 0;    // relative to the MuJoCo value
  double of_max = 0;  // relative to the field's largest MuJoCo value
};

// One compared field (or, with `exact`, a count that must match).
struct FieldCheck {
  std::string stage;  // the MuJoCo function that computes the field
  std::string field;
  Tolerance tol;
  bool exact = false;     // integers: every value must match
  long count = 0;         // values compared
  long mismatched = 0;    // values outside the tolerance
  double max_abs = 0;     // largest |engine - mujoco|
  double max_ratio = 0;   // largest |engine - mujoco| / bound (<= 1 passes)
  std::string worst;      // world and index of the largest ratio
  bool pass() const { return mismatched == 0 && count > 0; }
};

struct ParityReport {
  std::string engine;  // Engine::describe()
  std::string check;   // "forward", "step", "trajectory"
  std::vector<FieldCheck> fields;
  double seconds = 0;  // wall time of the check
  bool pass() const;
  // One line per field: stage, field, count, max error, ratio to the tolerance, PASS/FAIL.
  std::string table() const;
  // The failing fields only, one line each ("" when all pass).
  std::string failures() const;
};

// Tolerance of a stage's fields, by MuJoCo function name ("mj_kinematics", ..., "mj_Euler",
// "trajectory"), for float64 or float32 engines.
Tolerance stage_tolerance(const std::string& stage, bool float32);

// MJCF of a small model with the features the two-hand scene does not use (springs, a limited
// ball joint, a welded body, fixed tendons with spring, damper, friction, limits, an equality and
// an actuator, a polynomial joint coupling, affine gain and bias, a velocity servo, a motor with
// gear, a free body), contacts disabled.
const char* features_mjcf();

// A copy of `m` with contacts disabled (mjDSBL_CONTACT): what part 1 of the engine simulates.
// Free it with mj_deleteModel.
mjModel* contact_free_copy(const mjModel* m);

// All stages of mj_forward (kinematics ... mj_fwdConstraint) at random states.
ParityReport check_forward(const mjModel* m, const ModelArrays& arrays, Engine& engine,
                           uint64_t seed, bool float32);

// One mj_step (forward + Euler with implicit damping) from random states.
ParityReport check_step(const mjModel* m, const ModelArrays& arrays, Engine& engine,
                        uint64_t seed, bool float32);

// `seconds` of simulated time from the model's reference pose with small random velocities,
// new uniform random controls every `hold` steps, and a constant applied force per body
// (`xfrc`, nbody x 6, may be empty), compared after every control period.
ParityReport check_trajectory(const mjModel* m, const ModelArrays& arrays, Engine& engine,
                              uint64_t seed, bool float32, double seconds, int hold,
                              const std::vector<double>& xfrc);

}  // namespace bidex::sim::gpu
