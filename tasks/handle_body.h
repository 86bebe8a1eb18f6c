// The two-handle family's stage bodies (tasks/README.md): HandleProgram, everything the stages
// need of a bound lift or door task as plain numbers, and the four stages over one world's rows,
// written once for host and device (core/hd.h). HandleTask (tasks/handle_family.h) builds the
// program and calls the bodies with the CPU batch's double rows.
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

struct HandleProgram {
  HandRig hands[2];  // right, left
  bool pot = true;   // the pot (lift_underarm) or the door
  int body = -1, root_tree = -1, mocap = -1;  // the pot or the door's fixed frame; goal marker
  int handle_body[2] = {-1, -1};
  double handle_local[2][3] = {};             // handle points in their bodies' frames
  int hinge_qpos[2] = {-1, -1}, hinge_dof[2] = {-1, -1};  // door leaves (right, left)
  double goal_pos[3] = {};  // the pot's goal, or the door's own position
  double start_angle = 0;   // door leaves at every reset (rad)
  // reward
  bool palm_distance = true;
  bool target_y_gap = false;  // doors: d_target is |y_R - y_L| (the original), not |h_R - h_L|
  double constant = 0, goal_weight = 0, goal_offset = 0, goal_gate = 0;
  int t_const = -1, t_right = -1, t_left = -1, t_goal = -1;
  // success, termination
  double success_distance = 0, success_gap = 0;
  bool success_wider = true;
  double drop_height = 0, max_hand_distance = 0;
};
static_assert(std::is_trivially_copyable_v<HandleProgram>, "copied to the device as bytes");

// World position of the right (h = 0) or left (h = 1) handle point.
template <class Real>
BIDEX_HD void handle_point(const HandleProgram& p, const sim::WorldRows<Real>& w, int h,
                           Real* out) {
  const int b = p.handle_body[h];
  Real local[3];
  for (int k = 0; k < 3; ++k) local[k] = Real(p.handle_local[h][k]);
  math::frame_point(out, w.xpos + 3 * b, w.xquat + 4 * b, local);
}
// The reward's d_hand of hand h (0 right, 1 left) to its handle.
template <class Real>
BIDEX_HD Real handle_hand_distance(const HandleProgram& p, const sim::WorldRows<Real>& w, int h) {
  Real hp[3];
  handle_point(p, w, h, hp);
  if (!p.palm_distance) return tip_distance_sum(p.hands[h], w, hp);
  Real palm[3];
  palm_point(p.hands[h], w, palm);
  return math::dist3(palm, hp);
}
// The reward's d_target: pot to goal, or handle to handle (their distance, or the original's
// distance in y alone).
template <class Real>
BIDEX_HD Real handle_target_distance(const HandleProgram& p, const sim::WorldRows<Real>& w,
                                     const SlotState& st) {
  if (p.pot) {
    Real g[3];
    for (int k = 0; k < 3; ++k) g[k] = Real(st.goal[0][k]);
    return math::dist3(w.xpos + 3 * p.body, g);
  }
  Real r[3], l[3];
  handle_point(p, w, 0, r);
  handle_point(p, w, 1, l);
  return p.target_y_gap ? math::abs(r[1] - l[1]) : math::dist3(r, l);
}

// New episode: the simulation has restored the scene's state (hands at their mounts at rest,
// the pot at its start at rest, the leaves closed); the door tasks set their leaves' start
// angle. No randomisation, as in the original.
template <class Real>
BIDEX_HD void handle_reset(const HandleProgram& p, const sim::ResetRows<Real>& r, SlotState& st,
                           SlotRng& rng) {
  auto& goal = st.goal[0];
  for (int k = 0; k < 3; ++k) goal[k] = p.goal_pos[k];
  goal[3] = 1;
  goal[4] = goal[5] = goal[6] = 0;
  if (p.pot) {
    for (int k = 0; k < 3; ++k) r.mocap_pos[3 * p.mocap + k] = Real(goal[k]);
  } else {
    for (int h = 0; h < 2; ++h) {
      r.qpos[p.hinge_qpos[h]] = Real(p.start_angle);
      r.qvel[p.hinge_dof[h]] = 0;
    }
  }
}

template <class Real>
BIDEX_HD void handle_apply_actions(const HandleProgram& p, const float* a,
                                   const sim::WorldRows<Real>& w) {
  apply_two_hand_actions(p.hands, a, w);
}

// r = constant - d_right - d_left + goal_weight (goal_offset - d_target); success; termination.
template <class Real>
BIDEX_HD bool handle_evaluate(const HandleProgram& p, const sim::WorldRows<Real>& w,
                              SlotState& st, SlotRng&, Real* terms) {
  const Real dr = handle_hand_distance(p, w, 0), dl = handle_hand_distance(p, w, 1);
  const Real dt = handle_target_distance(p, w, st);
  terms[p.t_const] = Real(p.constant);
  terms[p.t_right] = -dr;
  terms[p.t_left] = -dl;
  const Real gate_at = Real(p.goal_gate);
  const bool gate = p.goal_gate <= 0 || (dr < gate_at && dl < gate_at);
  terms[p.t_goal] = gate ? Real(p.goal_weight) * (Real(p.goal_offset) - dt) : Real(0);

  // success (kept until the reset)
  bool success;
  if (p.pot) {
    success = dt < Real(p.success_distance);
  } else {
    Real r[3], l[3];
    handle_point(p, w, 0, r);
    handle_point(p, w, 1, l);
    const Real gap = math::abs(r[1] - l[1]);
    success = p.success_wider ? gap > Real(p.success_gap) : gap < Real(p.success_gap);
  }
  if (success) st.success = true;

  // termination: a hand too far from its handle, the pot dropped
  const Real far = Real(p.max_hand_distance);
  bool end = p.max_hand_distance > 0 && (dr >= far || dl >= far);
  if (p.pot && w.xpos[3 * p.body + 2] <= Real(p.drop_height)) end = true;
  return end;
}

// Both hand blocks, the object block (13), the goal block (11), the two handle points (3 + 3).
template <class Real>
BIDEX_HD void handle_observe(const HandleProgram& p, const sim::WorldRows<Real>& w,
                             const SlotState& st, float* obs) {
  float* o = observe_two_hands(p.hands, w, st.action.data(), obs);
  observe_object(w, p.body, p.root_tree, o);
  observe_goal(st.goal[0].data(), w.xquat + 4 * p.body, o + 13);
  o += 24;
  for (int h = 0; h < 2; ++h) {
    Real x[3];
    handle_point(p, w, h, x);
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(x[k]);
  }
}

}  // namespace bidex::tasks
