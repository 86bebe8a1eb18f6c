// SlotState: the mutable per-slot task state beside the simulation state. Plain data, the same
// on host and device (stage bodies read and write it; std::array's members are constexpr, which
// device code calls under nvcc's --expt-relaxed-constexpr).
#pragma once

#include <array>
#include <type_traits>

#include "core/hd.h"
#include "tasks/math.h"

namespace bidex::tasks {

constexpr int kMaxActions = 64;
constexpr int kMaxGoals = 2;
constexpr int kMaxTerms = 16;

// A slot's task parameters: set from outside (TaskEnv::set_goal_shifts, meta-RL's task
// sampling) and kept across the slot's episodes, unlike the rest of SlotState. A family reads
// only what its TaskSpec::goal_shifts says.
struct TaskParams {
  // added to each goal's configured position at every reset (m)
  std::array<std::array<double, 3>, kMaxGoals> goal_shift{};
  // a training curriculum's level in [0, 1] (families that have one, e.g. re_orientation's;
  // the family moves it from episode to episode), valid once level_started (zero bytes, as the
  // GPU backend's first state, mean not started)
  double level = 0;
  bool level_started = false;
};

struct SlotState {
  TaskParams params;         // kept by new_episode(), see above
  int progress = 0;          // control steps since the reset
  bool success = false;      // the success condition held at some step of this episode
  bool bonus_paid = false;   // the one-off goal bonus of this episode was paid
  unsigned goals_reached = 0;  // bit i: goal i was reached in this episode (families that
                               // count goals one by one: re_orientation's goal_mode each)
  // families that pay progress towards a goal (re_orientation's rotation_progress): each goal's
  // error at the last step, valid once has_last_error (cleared at every reset)
  std::array<double, kMaxGoals> last_error{};
  bool has_last_error = false;
  bool nonfinite_obs = false;  // the last observation had a non-finite value (set to 0): the
                               // next step faults the world instead of evaluating it
  // goal poses: position (3) then orientation (w, x, y, z)
  std::array<std::array<double, 7>, kMaxGoals> goal{};
  // this step's actions, clipped to [-1, 1] (zeros right after a reset)
  std::array<float, kMaxActions> action{};
};
static_assert(std::is_trivially_copyable_v<SlotState>, "copied to the device as bytes");

// A running episode's observation row, clipped to [-c, c] in place; a non-finite value is set to
// 0 and flags the slot, which faults at its next step (both backends: tasks/README.md, "Faults").
BIDEX_HD inline void clip_observation(float* o, int n, float c, SlotState& st) {
  if (!math::clip_finite(o, n, c)) st.nonfinite_obs = true;
}

// A new episode's state: everything cleared but the slot's task parameters.
BIDEX_HD inline void new_episode(SlotState& st) {
  const TaskParams keep = st.params;
  st = SlotState{};
  st.params = keep;
}

}  // namespace bidex::tasks
