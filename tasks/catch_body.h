// The throw-and-catch family's stage bodies (tasks/README.md): CatchProgram, everything the
// stages need of a bound task as plain numbers, and the four stages over one world's rows,
// written once for host and device (core/hd.h). CatchTask (tasks/catch_family.h) builds the
// program in bind() and calls the bodies with the CPU batch's double rows.
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

struct CatchProgram {
  HandRig hands[2];  // right, left
  int nact = 0;      // action width (the action penalty's sum)
  int nobj = 1;      // 1 or 2 objects
  struct Object {
    int body = -1, qpos = -1, mocap = -1, root_tree = -1;
    double start[3] = {};  // start position
    double goal[3] = {};   // goal position
  };
  Object obj[kMaxGoals];
  // reset
  double lift = 0;  // start height added for objects larger than the egg (README)
  double object_position_noise = 0;
  bool random_object_rotation = true;
  bool random_goal_rotation = true;
  double hand_dof_noise = 0;
  // reward
  double dist_weight = 0, success_tolerance = 0, action_penalty = 0, goal_bonus = 0;
  double fall_penalty = 0;
  int t_pose[2] = {-1, -1}, t_bonus = -1, t_fall = -1, t_action = -1;
  // termination
  double drop_height = 0;
  double max_root_drift = 0, max_palm_drift = 0;  // 0: off
  double root_anchor[2][3] = {}, palm_anchor[2][3] = {};
};
static_assert(std::is_trivially_copyable_v<CatchProgram>, "copied to the device as bytes");

// Distance and rotation distance of object i to its goal (the reward's d and theta).
template <class Real>
BIDEX_HD void catch_goal_error(const CatchProgram& p, const sim::WorldRows<Real>& w,
                               const SlotState& st, int i, Real* d, Real* theta) {
  const Real* pos = w.xpos + 3 * p.obj[i].body;
  const Real* quat = w.xquat + 4 * p.obj[i].body;
  Real g[7];
  for (int k = 0; k < 7; ++k) g[k] = static_cast<Real>(st.goal[i][k]);
  *d = math::dist3(pos, g);
  *theta = math::rot_distance(quat, g + 3);
}

// New episode (the world at the scene's initial state): hand joint noise, one shared
// position-noise sample and one orientation for the objects, one orientation for the goals.
template <class Real>
BIDEX_HD void catch_reset(const CatchProgram& p, const sim::ResetRows<Real>& r, SlotState& st,
                          SlotRng& rng) {
  // hands: one joint sample for both (as the original), inside the joint ranges
  randomise_hand_joints(p.hands, p.hand_dof_noise, rng, r);
  // objects: one position-noise sample and one orientation for all of them
  double noise[3] = {0, 0, 0};
  if (p.object_position_noise > 0)
    for (double& x : noise) x = p.object_position_noise * rng.uniform(-1, 1);
  double qo[4] = {1, 0, 0, 0}, qg[4] = {1, 0, 0, 0};
  if (p.random_object_rotation) math::random_rotation(qo, rng);
  if (p.random_goal_rotation) math::random_rotation(qg, rng);
  for (int i = 0; i < p.nobj; ++i) {
    const auto& o = p.obj[i];
    Real* q = r.qpos + o.qpos;
    double x[3];
    for (int k = 0; k < 3; ++k) x[k] = o.start[k] + noise[k];
    x[2] += p.lift;
    for (int k = 0; k < 3; ++k) q[k] = static_cast<Real>(x[k]);
    for (int k = 0; k < 4; ++k) q[3 + k] = static_cast<Real>(qo[k]);
    auto& goal = st.goal[i];
    for (int k = 0; k < 3; ++k) goal[k] = o.goal[k] + st.params.goal_shift[i][k];
    for (int k = 0; k < 4; ++k) goal[3 + k] = qg[k];
    for (int k = 0; k < 3; ++k) r.mocap_pos[3 * o.mocap + k] = static_cast<Real>(goal[k]);
    for (int k = 0; k < 4; ++k) r.mocap_quat[4 * o.mocap + k] = static_cast<Real>(goal[3 + k]);
  }
}

// Clipped actions -> joint targets and base forces.
template <class Real>
BIDEX_HD void catch_apply_actions(const CatchProgram& p, const float* a,
                                  const sim::WorldRows<Real>& w) {
  apply_two_hand_actions(p.hands, a, w);
}

// After physics: the reward terms, success; returns whether the episode terminated.
template <class Real>
BIDEX_HD bool catch_evaluate(const CatchProgram& p, const sim::WorldRows<Real>& w, SlotState& st,
                             SlotRng&, Real* terms) {
  Real dsum = 0;
  bool fell = false;
  for (int i = 0; i < p.nobj; ++i) {
    Real d, theta;
    catch_goal_error(p, w, st, i, &d, &theta);
    terms[p.t_pose[i]] = math::exp(Real(-0.2) * (Real(p.dist_weight) * d + theta));
    dsum += d;
    if (w.xpos[3 * p.obj[i].body + 2] <= Real(p.drop_height)) fell = true;
  }
  // success: the object within tolerance (two objects: the sum of distances)
  if (dsum < Real(p.success_tolerance) && !st.success) {
    st.success = true;
    if (!st.bonus_paid) {
      terms[p.t_bonus] = Real(p.goal_bonus);
      st.bonus_paid = true;
    }
  }
  double a2 = 0;
  for (int k = 0; k < p.nact; ++k) a2 += double(st.action[k]) * st.action[k];
  terms[p.t_action] = Real(p.action_penalty * a2);
  if (fell) terms[p.t_fall] = Real(p.fall_penalty);

  bool drift = false;
  for (int h = 0; h < 2; ++h) {
    Real root[3], palm[3];
    for (int k = 0; k < 3; ++k) {
      root[k] = Real(p.root_anchor[h][k]);
      palm[k] = Real(p.palm_anchor[h][k]);
    }
    const Real* xr = w.xpos + 3 * p.hands[h].root_body;
    const Real* xp = w.xpos + 3 * p.hands[h].palm_body;
    if (p.max_root_drift > 0 && math::dist3(xr, root) >= Real(p.max_root_drift)) drift = true;
    if (p.max_palm_drift > 0 && math::dist3(xp, palm) >= Real(p.max_palm_drift)) drift = true;
  }
  return fell || drift;
}

// The observation: both hand blocks, then per object its block (13) and its goal block (11).
template <class Real>
BIDEX_HD void catch_observe(const CatchProgram& p, const sim::WorldRows<Real>& w,
                            const SlotState& st, float* obs) {
  float* o = observe_two_hands(p.hands, w, st.action.data(), obs);
  for (int i = 0; i < p.nobj; ++i) {
    const int b = p.obj[i].body;
    observe_object(w, b, p.obj[i].root_tree, o);
    observe_goal(st.goal[i].data(), w.xquat + 4 * b, o + 13);
    o += 24;
  }
}

}  // namespace bidex::tasks
