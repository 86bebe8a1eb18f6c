// SimBatch: the mutable state of N slots (worlds) of one SimModel, and the functions that step
// and reset them in parallel over all cores. Every array leads with the slot dimension.
//
// The step, per slot, inside one parallel loop (OpenMP, any thread count gives bitwise identical
// results because slots never share mutable state and each has its own random stream):
//   1. inputs: ctrl and base_wrench rows are checked (non-finite -> fault) and copied in
//   2. physics: `substeps` MuJoCo steps
//   3. faults: non-finite or exploding state, a MuJoCo warning or error flags and resets the slot
//   4. outputs: state rows (qpos, qvel, ...) are copied out
//   0. the caller's `pre` hook (tasks: actions -> ctrl and base_wrench rows)
//   5. the caller's `post` hook (tasks: rewards, resets, observations) runs on the same core
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <random>
#include <vector>

#include "core/rng.h"
#include "sim/model.h"

struct mjData_;
typedef struct mjData_ mjData;

namespace bidex::sim {

// The fields of a batch, listed once: name, values per slot (an expression of SimModel `m`),
// and who writes it. Allocation, copies, NaN fill and the Python/torch views derive from this.
#define BIDEX_BATCH_INPUTS(X)                                                           \
  X(ctrl, m.nu(), "input: actuator targets (rad), written by the caller / apply_actions") \
  X(base_wrench, m.nwrench(), "input: world-frame force (N) and torque (N m) per hand base")

// Each output is named after the mjData field it copies (the step copies them by that name).
#define BIDEX_BATCH_OUTPUTS(X)                                                              \
  X(qpos, m.nq(), "output: generalized positions, written by step")                         \
  X(qvel, m.nv(), "output: generalized velocities, written by step")                        \
  X(qfrc_actuator, m.nv(), "output: actuator force per dof, written by step")               \
  X(qfrc_constraint, m.nv(), "output: constraint force per dof, written by step")           \
  X(sensordata, m.nsensordata(), "output: sensor values (fingertip force/torque), by step") \
  X(xpos, m.nbody() * 3, "output: body positions (world), written by step")                 \
  X(xquat, m.nbody() * 4, "output: body orientations (w, x, y, z), written by step")        \
  X(cvel, m.nbody() * 6, "output: body com-based velocities (rot, lin), written by step")    \
  X(subtree_com, m.nbody() * 3, "output: centre of mass of each body's subtree (cvel's origin)")

// Why a slot was reset after a step (bits of SimBatch::fault).
enum FaultBits : uint32_t {
  kFaultNone = 0,
  kFaultBadInput = 1u << 0,     // non-finite ctrl or base wrench
  kFaultNonFinite = 1u << 1,    // non-finite qpos/qvel/qacc after the step
  kFaultExploded = 1u << 2,     // |qvel| above PhysicsOptions::max_speed
  kFaultMujocoWarn = 1u << 3,   // MuJoCo warned (bad qacc, contact/constraint buffer full, ...)
  kFaultMujocoError = 1u << 4,  // MuJoCo raised an error (e.g. its mjData stack overflowed)
  kFaultOverflow = 1u << 5,     // GPU backend: a world ran out of constraint rows or contacts
};
constexpr int kFaultKinds = 6;
// Bit k's name in reports: bad_input, non_finite, exploded, mujoco_warning, mujoco_error,
// overflow.
inline const char* fault_kind_name(int k) {
  static const char* const names[kFaultKinds] = {"bad_input",      "non_finite",   "exploded",
                                                 "mujoco_warning", "mujoco_error", "overflow"};
  return k >= 0 && k < kFaultKinds ? names[k] : "unknown";
}

struct BatchOptions {
  int threads = 0;        // 0: all cores (OpenMP default)
  uint64_t seed = 0;      // run seed of the per-slot random streams
};

// A view of one slot's state rows (pointers into the batch's contiguous arrays).
struct SlotView {
#define BIDEX_X(name, width, doc) double* name;
  BIDEX_BATCH_INPUTS(BIDEX_X)
  BIDEX_BATCH_OUTPUTS(BIDEX_X)
#undef BIDEX_X
};

class SimBatch {
 public:
  SimBatch(const SimModel& model, int nslot, BatchOptions options = {});
  ~SimBatch();
  SimBatch(const SimBatch&) = delete;
  SimBatch& operator=(const SimBatch&) = delete;

  int nslot() const { return nslot_; }
  int threads() const { return threads_; }
  void set_threads(int n);
  const SimModel& model() const { return *model_; }

  // contiguous arrays, (nslot, width) row-major
#define BIDEX_X(name, width, doc) \
  std::vector<double> name;      \
  int name##_width = 0;
  BIDEX_BATCH_INPUTS(BIDEX_X)
  BIDEX_BATCH_OUTPUTS(BIDEX_X)
#undef BIDEX_X

  std::vector<double> time;           // (nslot) simulated seconds since the slot's last reset
  std::vector<uint32_t> fault;        // (nslot) FaultBits of the last step, 0 if none
  std::vector<int64_t> fault_count;   // (nslot) faults since construction
  // (nslot) the physics' load, summed over the slot's control steps since construction: the
  // constraint rows at each step's end (mjData::nefc) and the solver's iterations in its last
  // substep (the most of any island); the GPU backend keeps the same sums (sim/warp_bridge.py)
  std::vector<int64_t> efc_rows;
  std::vector<int64_t> solver_iters;
  std::vector<int64_t> episode;       // (nslot) resets so far (seeds the random stream)

  SlotView slot(int s);
  // The slot's random stream, keyed by (seed, slot, episode) at every reset (core/rng.h).
  SlotRng& rng(int s) { return rng_[s]; }
  // The MuJoCo data of one slot (for task code that needs MuJoCo functions).
  mjData* data(int s) { return data_[s]; }
  const mjData* data(int s) const { return data_[s]; }

  int64_t total_faults() const;
  // Bytes held by the batch (all mjData plus the contiguous arrays).
  size_t bytes() const;

 private:
  friend void step(const SimModel&, SimBatch&, const std::function<void(int)>*,
                   const std::function<void(int)>*);
  friend void step_slot(const SimModel&, SimBatch&, int);
  friend void reset_slot(const SimModel&, SimBatch&, int, bool);
  friend void sync_slot(const SimModel&, SimBatch&, int);

  const SimModel* model_;
  int nslot_ = 0;
  int threads_ = 1;
  uint64_t seed_ = 0;
  std::vector<mjData*> data_;
  std::vector<SlotRng> rng_;
  std::vector<int> warnings_seen_;  // (nslot) MuJoCo warning total before the step
};

// Steps every slot by one control step (`substeps` physics steps). `pre` (optional) runs per slot
// before its inputs are read (tasks write ctrl and base_wrench rows from actions there); `post`
// (optional) runs per slot after outputs are written. Both run on the thread that steps the slot,
// inside the parallel loop, so they must not throw (flag problems per slot instead, as the step
// does). Never throws for bad state: faulty slots are flagged in `fault`, counted and reset.
void step(const SimModel& model, SimBatch& batch,
          const std::function<void(int)>* post = nullptr,
          const std::function<void(int)>* pre = nullptr);

// Steps 1-4 of `step` for one slot (inputs, substeps, faults, outputs or the reset of a faulty
// slot), for callers that run their own parallel loop (a pack of several tasks steps the slots
// of all its batches in one loop). Touches nothing but the slot's own rows and data, so slots
// may be stepped concurrently and in any order; never throws for bad state.
void step_slot(const SimModel& model, SimBatch& batch, int slot);

// The solver's iterations in a slot's last physics step: the most of any constraint island
// (what SimBatch::solver_iters sums).
int solver_iterations(const mjData* d);

// Puts one slot back to the scene's initial state (hands at their placements, joints at 0 inside
// their ranges, targets at the current joints, zero velocity), advances its episode counter,
// rekeys its random stream and writes its output rows.
// forward = false leaves the derived quantities and the output rows to a sync_slot call of the
// caller, who edits the state first (tasks: randomised joints and objects), so the reset runs
// MuJoCo's forward pass once instead of twice.
void reset_slot(const SimModel& model, SimBatch& batch, int slot, bool forward = true);
void reset_all(const SimModel& model, SimBatch& batch);

// After task code edits a slot's mjData (qpos, qvel) directly: recompute derived quantities and
// rewrite the slot's output rows.
void sync_slot(const SimModel& model, SimBatch& batch, int slot);

// Writes one slot's inputs into its MuJoCo data: actuator targets, and each free base's
// world-frame force and torque as applied forces (the hands' weight is cancelled by MuJoCo's
// gravcomp, scene.cc). A base force
// acts at the base's pivot (the mount origin, where the ball joint turns), so a push translates
// the hand without turning it. Used by `step`; public so that benchmarks drive worlds the same way.
void apply_inputs(const SimModel& model, mjData* d, const double* ctrl, const double* wrench);
// Rewrites only the free bases' rows of the applied forces for the current pose (the pivot's
// offset from the centre of mass turns with the base): between the substeps of one control step.
void update_base_wrench(const SimModel& model, mjData* d, const double* wrench);

// MuJoCo warnings a slot's data has counted; a change across a step is a kFaultMujocoWarn.
int warning_total(const mjData* d);

// Uniform in [lo, hi) from 53 bits of a caller's stream (random actions, not the slots'): the
// same on every platform (unlike std::uniform_real_distribution), so seeded results do not
// depend on the standard library. A slot's stream has its own (SlotRng::uniform).
double uniform(std::mt19937_64& rng, double lo, double hi);

// Writes uniformly random inputs into every slot's rows from its own stream: actuator targets
// over their control ranges, base forces/torques up to the given magnitudes.
void random_inputs(const SimModel& model, SimBatch& batch, double max_force, double max_torque);

}  // namespace bidex::sim
