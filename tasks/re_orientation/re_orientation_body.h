// re_orientation's stage bodies (tasks/README.md): ReOrientationProgram and the four stages over
// one world's rows, for host and device. ReOrientation (re_orientation.h) builds the program in
// bind().
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

struct ReOrientationProgram {
  HandRig hands[2];  // right, left
  int nact = 0;      // action width (the action penalty's sum)
  struct Object {
    int body = -1, qpos = -1, mocap = -1, root_tree = -1;
    double start[3] = {}, goal[3] = {};  // start and goal positions
  };
  Object obj[2];
  // reset
  double object_position_noise = 0;
  bool random_object_rotation = true, random_goal_rotation = true;
  double hand_dof_noise = 0;
  // reward: dist_scale (d1 + d2) + rot_scale / (theta_i + rot_eps) + action_penalty sum(a^2)
  // + rotation_progress sum_i (theta_i at the last step - theta_i) (0: off, the default)
  double dist_scale = 0, rot_scale = 0, rot_eps = 0, action_penalty = 0, rotation_progress = 0;
  double goal_bonus = 0, rotation_tolerance = 0;
  bool each_goal = false;  // goal_mode each: a cube at its goal gets its own new goal
  // curriculum (off by default; README "Learning"): a slot's level L (TaskParams::level) starts
  // at curriculum_start, gains curriculum_up at every goal reached (a bonus) and loses
  // curriculum_down at every reset, within [0, 1]; a new goal orientation is the last one (at a
  // reset the cubes' start orientation) turned about a random axis by an angle uniform in
  // [0, L pi]
  bool curriculum = false;
  double curriculum_start = 0, curriculum_up = 0, curriculum_down = 0;
  double drop_height = 0;
  int t_pos = -1, t_rot[2] = {-1, -1}, t_bonus = -1, t_action = -1, t_progress = -1;
};
static_assert(std::is_trivially_copyable_v<ReOrientationProgram>,
              "copied to the device as bytes");

// The goals in `which` (bit i: goal i) get one new random orientation, shared (the original's
// shared goal rotation); under the curriculum, `from` turned by at most the slot's level x pi.
BIDEX_HD inline void re_orientation_new_goals(const ReOrientationProgram& p, SlotState& st,
                                              SlotRng& rng, unsigned which, const double* from) {
  double q[4] = {1, 0, 0, 0};
  if (p.curriculum) {
    const double z = rng.uniform(-1, 1), phi = rng.uniform(0, 2 * math::kPi);
    const double r = math::sqrt(math::max(0.0, 1 - z * z));
    const double axis[3] = {r * math::cos(phi), r * math::sin(phi), z};
    double turn[4];
    math::axis_angle_quat(turn, axis, rng.uniform(0, 1) * st.params.level * math::kPi);
    math::mul_quat(q, turn, from);
  } else if (p.random_goal_rotation) {
    math::random_rotation(q, rng);
  }
  for (int i = 0; i < 2; ++i) {
    if (!(which & (1u << i))) continue;
    auto& g = st.goal[i];
    for (int k = 0; k < 3; ++k) g[k] = p.obj[i].goal[k];
    for (int k = 0; k < 4; ++k) g[3 + k] = q[k];
  }
}

// The goal markers at the goals (no-op without marker rows).
template <class Real>
BIDEX_HD void re_orientation_place_markers(const ReOrientationProgram& p, const SlotState& st,
                                           Real* mocap_pos, Real* mocap_quat) {
  if (!mocap_pos || !mocap_quat) return;
  for (int i = 0; i < 2; ++i) {
    const int m = p.obj[i].mocap;
    for (int k = 0; k < 3; ++k) mocap_pos[3 * m + k] = static_cast<Real>(st.goal[i][k]);
    for (int k = 0; k < 4; ++k) mocap_quat[4 * m + k] = static_cast<Real>(st.goal[i][3 + k]);
  }
}

// New episode: hand joint noise, one shared position-noise sample and one orientation for the
// cubes, new goals (and their markers).
template <class Real>
BIDEX_HD void re_orientation_reset(const ReOrientationProgram& p, const sim::ResetRows<Real>& r,
                                   SlotState& st, SlotRng& rng) {
  if (p.curriculum) {
    double& level = st.params.level;
    level = st.params.level_started ? math::max(0.0, level - p.curriculum_down)
                                    : p.curriculum_start;
    st.params.level_started = true;
  }
  randomise_hand_joints(p.hands, p.hand_dof_noise, rng, r);
  double noise[3] = {0, 0, 0};
  if (p.object_position_noise > 0)
    for (double& x : noise) x = p.object_position_noise * rng.uniform(-1, 1);
  double qo[4] = {1, 0, 0, 0};
  if (p.random_object_rotation) math::random_rotation(qo, rng);
  for (int i = 0; i < 2; ++i) {
    Real* q = r.qpos + p.obj[i].qpos;
    for (int k = 0; k < 3; ++k) q[k] = static_cast<Real>(p.obj[i].start[k] + noise[k]);
    for (int k = 0; k < 4; ++k) q[3 + k] = static_cast<Real>(qo[k]);
  }
  re_orientation_new_goals(p, st, rng, 3u, qo);
  re_orientation_place_markers(p, st, r.mocap_pos, r.mocap_quat);
}

template <class Real>
BIDEX_HD void re_orientation_apply_actions(const ReOrientationProgram& p, const float* a,
                                           const sim::WorldRows<Real>& w) {
  apply_two_hand_actions(p.hands, a, w);
}

// Distance and rotation distance of cube i to its goal.
template <class Real>
BIDEX_HD void re_orientation_goal_error(const ReOrientationProgram& p,
                                        const sim::WorldRows<Real>& w, const SlotState& st,
                                        int i, Real* d, Real* theta) {
  Real g[7];
  for (int k = 0; k < 7; ++k) g[k] = static_cast<Real>(st.goal[i][k]);
  *d = math::dist3(w.xpos + 3 * p.obj[i].body, g);
  *theta = math::rot_distance(w.xquat + 4 * p.obj[i].body, g + 3);
}

// The reward terms. goal_mode both: both cubes at their goal orientations at once give the bonus,
// success and new goals (drawn from the world's stream) with their markers moved. goal_mode
// each: every cube at its goal gives a bonus and gets a new goal (cubes at their goals at the
// same step share one new orientation); success once both have reached one in the episode.
// rotation_progress (when not 0) pays the decrease of each cube's rotation distance since the
// last step of the episode (nothing at its first step); a cube's new goal restarts its count
// from its distance to that goal. Ends when a cube falls.
template <class Real>
BIDEX_HD bool re_orientation_evaluate(const ReOrientationProgram& p,
                                      const sim::WorldRows<Real>& w, SlotState& st, SlotRng& rng,
                                      Real* terms) {
  Real d[2], th[2];
  bool fell = false;
  for (int i = 0; i < 2; ++i) {
    re_orientation_goal_error(p, w, st, i, &d[i], &th[i]);
    terms[p.t_rot[i]] = Real(p.rot_scale) / (math::abs(th[i]) + Real(p.rot_eps));
    if (w.xpos[3 * p.obj[i].body + 2] <= Real(p.drop_height)) fell = true;
  }
  terms[p.t_pos] = Real(p.dist_scale) * (d[0] + d[1]);
  double a2 = 0;
  for (int k = 0; k < p.nact; ++k) a2 += double(st.action[k]) * st.action[k];
  terms[p.t_action] = Real(p.action_penalty * a2);
  const Real tol = Real(p.rotation_tolerance);
  unsigned at = 0;
  for (int i = 0; i < 2; ++i)
    if (th[i] < tol) at |= 1u << i;
  if (p.each_goal) {
    terms[p.t_bonus] = Real(p.goal_bonus) * Real((at & 1u) + (at >> 1));
    st.goals_reached |= at;
    if (st.goals_reached == 3u) st.success = true;
  } else {
    at = at == 3u ? 3u : 0u;
    terms[p.t_bonus] = at ? Real(p.goal_bonus) : Real(0);
    if (at) st.success = true;
  }
  if (at) {
    if (p.curriculum) st.params.level = math::min(1.0, st.params.level + p.curriculum_up);
    const auto& last = st.goal[at & 1u ? 0 : 1];  // a goal just reached
    const double from[4] = {last[3], last[4], last[5], last[6]};
    re_orientation_new_goals(p, st, rng, at, from);
    re_orientation_place_markers(p, st, w.mocap_pos, w.mocap_quat);
  }
  if (p.rotation_progress != 0) {
    Real gain = 0;
    for (int i = 0; i < 2; ++i) {
      if (st.has_last_error) gain += Real(st.last_error[i]) - th[i];
      if (at & (1u << i)) re_orientation_goal_error(p, w, st, i, &d[i], &th[i]);  // its new goal
      st.last_error[i] = th[i];
    }
    st.has_last_error = true;
    terms[p.t_progress] = Real(p.rotation_progress) * gain;
  } else {
    terms[p.t_progress] = 0;
  }
  return fell;
}

// Both hand blocks, then per cube its object block (13) and goal block (11).
template <class Real>
BIDEX_HD void re_orientation_observe(const ReOrientationProgram& p,
                                     const sim::WorldRows<Real>& w, const SlotState& st,
                                     float* obs) {
  float* o = observe_two_hands(p.hands, w, st.action.data(), obs);
  for (int i = 0; i < 2; ++i) {
    const int b = p.obj[i].body;
    observe_object(w, b, p.obj[i].root_tree, o);
    observe_goal(st.goal[i].data(), w.xquat + 4 * b, o + 13);
    o += 24;
  }
}

}  // namespace bidex::tasks
