// block_stack's stage bodies (tasks/README.md): BlockStackProgram and the four stages over one
// world's rows, for host and device. BlockStack (block_stack.h) builds the program in bind().
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

struct BlockStackProgram {
  HandRig hands[2];        // right, left
  int body[2] = {-1, -1};  // block1 (left hand's, on top), block2 (right hand's)
  int root_tree[2] = {-1, -1};
  double target[2][3] = {};  // each block's target position
  double goal[7] = {};       // the goal block: block 1's target, the blocks' start orientation
  // reward: offset - d_left - d_right + goal_scale (goal_offset - d_target) [+ stack bonus]
  double offset = 0, goal_scale = 0, goal_offset = 0;
  double goal_gate = 0;  // > 0: the goal term only while both hands' sums < it
  double stack_bonus_scale = 0, stack_tolerance = 0, height_tolerance = 0;
  double max_tip_distance = 0;  // 0: off
  int t_offset = -1, t_left = -1, t_right = -1, t_goal = -1, t_stack = -1;
};
static_assert(std::is_trivially_copyable_v<BlockStackProgram>, "copied to the device as bytes");

// New episode: blocks at their start poses (the simulation's reset); the goal is fixed.
template <class Real>
BIDEX_HD void block_stack_reset(const BlockStackProgram& p, const sim::ResetRows<Real>&,
                                SlotState& st, SlotRng&) {
  for (int k = 0; k < 7; ++k) st.goal[0][k] = p.goal[k];
}

template <class Real>
BIDEX_HD void block_stack_apply_actions(const BlockStackProgram& p, const float* a,
                                        const sim::WorldRows<Real>& w) {
  apply_two_hand_actions(p.hands, a, w);
}

// The reward terms, success (both placed, block 1 at its height); ends when a hand strays.
template <class Real>
BIDEX_HD bool block_stack_evaluate(const BlockStackProgram& p, const sim::WorldRows<Real>& w,
                                   SlotState& st, SlotRng&, Real* terms) {
  const TwoBlockReach<Real> r = two_block_reach(p.hands, w, p.body, p.target[0], p.target[1]);
  terms[p.t_offset] = Real(p.offset);
  terms[p.t_left] = -r.d_left;
  terms[p.t_right] = -r.d_right;
  const Real gate = Real(p.goal_gate);
  const bool gate_open = p.goal_gate <= 0 || (r.d_left < gate && r.d_right < gate);
  terms[p.t_goal] =
      gate_open ? Real(p.goal_scale) * (Real(p.goal_offset) - (r.e1 + r.e2)) : Real(0);
  const Real dz = math::abs(Real(p.target[0][2]) - r.b1[2]);
  const Real tol = Real(p.stack_tolerance);
  const bool placed = r.e1 < tol && r.e2 < tol;
  if (placed) terms[p.t_stack] = Real(p.stack_bonus_scale) * (Real(0.05) - dz);
  if (placed && dz < Real(p.height_tolerance)) st.success = true;
  return r.strayed(p.max_tip_distance);
}

// Both hand blocks, block 1's object and goal blocks, both blocks' positions.
template <class Real>
BIDEX_HD void block_stack_observe(const BlockStackProgram& p, const sim::WorldRows<Real>& w,
                                  const SlotState& st, float* obs) {
  float* o = observe_two_hands(p.hands, w, st.action.data(), obs);
  observe_object(w, p.body[0], p.root_tree[0], o);
  observe_goal(st.goal[0].data(), w.xquat + 4 * p.body[0], o + 13);
  math::put_vec3(o + 24, w.xpos + 3 * p.body[0]);
  math::put_vec3(o + 27, w.xpos + 3 * p.body[1]);
}

}  // namespace bidex::tasks
