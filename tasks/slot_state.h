// SlotState: the mutable per-slot task state beside the simulation state. Plain data, the same
// on host and device (stage bodies read and write it; std::array's members are constexpr, which
// device code calls under nvcc's --expt-relaxed-constexpr).
#pragma once

#include <array>
#include <type_traits>

namespace bidex::tasks {

constexpr int kMaxActions = 64;
constexpr int kMaxGoals = 2;
constexpr int kMaxTerms = 16;

struct SlotState {
  int progress = 0;          // control steps since the reset
  bool success = false;      // the success condition held at some step of this episode
  bool bonus_paid = false;   // the one-off goal bonus of this episode was paid
  // goal poses: position (3) then orientation (w, x, y, z)
  std::array<std::array<double, 7>, kMaxGoals> goal{};
  // this step's actions, clipped to [-1, 1] (zeros right after a reset)
  std::array<float, kMaxActions> action{};
};
static_assert(std::is_trivially_copyable_v<SlotState>, "copied to the device as bytes");

}  // namespace bidex::tasks
