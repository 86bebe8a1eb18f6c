// bottle_cap's stage bodies (tasks/README.md): BottleCapProgram and the four stages over one
// world's rows, for host and device. BottleCap (bottle_cap.h) builds the program in bind().
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

// Bottle frame: axis +z, origin at the bottle's centre, 0.275 m tall (-0.1375 to 0.1375).
constexpr double kBottleCapSeat = 0.12;  // cap body origin (the cap's centre) when closed

struct BottleCapProgram {
  HandRig hands[2];  // right, left
  int bottle = -1, root_tree = -1, cap = -1;
  double cap_point = 0;  // c = bottle origin + R (0, 0, cap_point)
  // reward: offset - d_right - d_left + open_scale d_open
  double offset = 0, open_scale = 0;
  double goal_gate = 0;  // > 0: the opening term only while d_right <= it
  double success_opening = 0;
  // termination
  double cap_drop_height = 0, max_right_palm = 0, max_left_palm = 0;  // palms: 0 off
  int t_offset = -1, t_right = -1, t_left = -1, t_open = -1;
};
static_assert(std::is_trivially_copyable_v<BottleCapProgram>, "copied to the device as bytes");

// The cap's distance from its closed seat (m): the paper's |x_bottle - x_cap| measured from
// where the cap sits when closed.
template <class Real>
BIDEX_HD Real bottle_cap_opening(const BottleCapProgram& p, const sim::WorldRows<Real>& w) {
  const Real seat_local[3] = {0, 0, Real(kBottleCapSeat)};
  Real seat[3];
  math::frame_point(seat, w.xpos + 3 * p.bottle, w.xquat + 4 * p.bottle, seat_local);
  return math::dist3(w.xpos + 3 * p.cap, seat);
}

// New episode: bottle at its start pose, cap closed (the simulation's reset).
template <class Real>
BIDEX_HD void bottle_cap_reset(const BottleCapProgram&, const sim::ResetRows<Real>&, SlotState&,
                               SlotRng&) {}

template <class Real>
BIDEX_HD void bottle_cap_apply_actions(const BottleCapProgram& p, const float* a,
                                       const sim::WorldRows<Real>& w) {
  apply_two_hand_actions(p.hands, a, w);
}

// The reward terms, success (the cap opened); ends when the cap drops or a palm strays.
template <class Real>
BIDEX_HD bool bottle_cap_evaluate(const BottleCapProgram& p, const sim::WorldRows<Real>& w,
                                  SlotState& st, SlotRng&, Real* terms) {
  const Real* b = w.xpos + 3 * p.bottle;
  const Real cap_local[3] = {0, 0, Real(p.cap_point)};
  Real c[3], palm_r[3], palm_l[3];
  math::frame_point(c, b, w.xquat + 4 * p.bottle, cap_local);
  palm_point(p.hands[0], w, palm_r);
  palm_point(p.hands[1], w, palm_l);
  const Real d_right = tip_distance_sum(p.hands[0], w, c);
  const Real d_left = math::dist3(b, palm_l);
  const Real d_open = bottle_cap_opening(p, w);
  terms[p.t_offset] = Real(p.offset);
  terms[p.t_right] = -d_right;
  terms[p.t_left] = -d_left;
  const bool gate_open = p.goal_gate <= 0 || d_right <= Real(p.goal_gate);
  terms[p.t_open] = gate_open ? Real(p.open_scale) * d_open : Real(0);
  if (d_open > Real(p.success_opening)) st.success = true;
  bool end = c[2] <= Real(p.cap_drop_height);
  if (p.max_right_palm > 0 && math::dist3(c, palm_r) >= Real(p.max_right_palm)) end = true;
  if (p.max_left_palm > 0 && d_left >= Real(p.max_left_palm)) end = true;
  return end;
}

// Both hand blocks, the bottle's object block, the cap's position.
template <class Real>
BIDEX_HD void bottle_cap_observe(const BottleCapProgram& p, const sim::WorldRows<Real>& w,
                                 const SlotState& st, float* obs) {
  float* o = observe_two_hands(p.hands, w, st.action.data(), obs);
  observe_object(w, p.bottle, p.root_tree, o);
  math::put_vec3(o + 13, w.xpos + 3 * p.cap);
}

}  // namespace bidex::tasks
