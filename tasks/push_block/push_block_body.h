// push_block's stage bodies (tasks/README.md): PushBlockProgram and the four stages over one
// world's rows, for host and device. PushBlock (push_block.h) builds the program in bind().
#pragma once

#include <type_traits>

#include "core/hd.h"
#include "core/rng.h"
#include "sim/state_view.h"
#include "tasks/hand_body.h"
#include "tasks/math.h"
#include "tasks/object_body.h"
#include "tasks/slot_state.h"

namespace bidex::tasks {

struct PushBlockProgram {
  HandRig hands[2];                   // right, left
  int body[2] = {-1, -1};             // block1 (left hand's), block2 (right hand's)
  int root_tree[2] = {-1, -1};
  double goal[2][7] = {};             // each block's goal pose: position, (w, x, y, z)
  // reward: offset - d_left - d_right + goal_scale (goal_offset - d_target)
  double offset = 0, goal_scale = 0, goal_offset = 0, success_tolerance = 0;
  double max_tip_distance = 0;        // 0: off
  int t_offset = -1, t_left = -1, t_right = -1, t_goal = -1;
};
static_assert(std::is_trivially_copyable_v<PushBlockProgram>, "copied to the device as bytes");

// New episode: blocks at their start poses (the simulation's reset); the goals are fixed.
template <class Real>
BIDEX_HD void push_block_reset(const PushBlockProgram& p, const sim::ResetRows<Real>&,
                               SlotState& st, SlotRng&) {
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 7; ++k) st.goal[i][k] = p.goal[i][k];
}

template <class Real>
BIDEX_HD void push_block_apply_actions(const PushBlockProgram& p, const float* a,
                                       const sim::WorldRows<Real>& w) {
  apply_two_hand_actions(p.hands, a, w);
}

// The reward terms, success (both blocks within tolerance); ends when a hand strays.
template <class Real>
BIDEX_HD bool push_block_evaluate(const PushBlockProgram& p, const sim::WorldRows<Real>& w,
                                  SlotState& st, SlotRng&, Real* terms) {
  const TwoBlockReach<Real> r = two_block_reach(p.hands, w, p.body, p.goal[0], p.goal[1]);
  terms[p.t_offset] = Real(p.offset);
  terms[p.t_left] = -r.d_left;
  terms[p.t_right] = -r.d_right;
  terms[p.t_goal] = Real(p.goal_scale) * (Real(p.goal_offset) - (r.e1 + r.e2));
  const Real tol = Real(p.success_tolerance);
  if (r.e1 <= tol && r.e2 <= tol) st.success = true;
  return r.strayed(p.max_tip_distance);
}

// Both hand blocks, block 1's object block, both blocks' positions.
template <class Real>
BIDEX_HD void push_block_observe(const PushBlockProgram& p, const sim::WorldRows<Real>& w,
                                 const SlotState& st, float* obs) {
  float* o = observe_two_hands(p.hands, w, st.action.data(), obs);
  observe_object(w, p.body[0], p.root_tree[0], o);
  math::put_vec3(o + 13, w.xpos + 3 * p.body[0]);
  math::put_vec3(o + 16, w.xpos + 3 * p.body[1]);
}

}  // namespace bidex::tasks
