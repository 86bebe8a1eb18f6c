// The hand half of every stage body: HandRig (where one hand's joints, motors, fingertips, palm
// and base live in the compiled scene; plain numbers, copied to the device as they are) and the
// per-slot hand functions over one world's rows (sim/state_view.h), written once for host and
// device: actions -> joint targets and base forces, the hand block of the observation, the
// reward points, joint resets. Binding a rig is host code (tasks/hands.h).
#pragma once

#include <type_traits>

#include "core/hd.h"
#include "core/rng.h"
#include "sim/state_view.h"
#include "tasks/math.h"

namespace bidex::tasks {

constexpr int kHandJoints = 24;  // tree order
constexpr int kHandMotors = 20;  // tree order
constexpr int kTips = 5;         // ff, mf, rf, lf, th
constexpr int kMaxCouplings = 4;  // coupled distal joints (no motor; follow their middle joint)
// Observation widths of one hand block, and action widths (20 joints, + 6 base values if free).
constexpr int kHandObsFixed = 187;
constexpr int kHandObsFree = 199;
constexpr int kHandActFixed = kHandMotors;
constexpr int kHandActFree = kHandMotors + 6;

struct HandRig {
  int hand = 0;              // index into SimModel::hands() (and the base_wrench row)
  bool free_base = false;
  int root_body = -1;        // forearm: the base
  int root_tree = -1;        // MuJoCo's body_rootid of the hand (origin of cvel)
  int palm_body = -1;
  int tip_body[kTips] = {}, tip_force_adr[kTips] = {}, tip_torque_adr[kTips] = {};
  // the joints
  int qpos_adr[kHandJoints] = {}, dof_adr[kHandJoints] = {};
  double lower[kHandJoints] = {}, upper[kHandJoints] = {};  // joint range (rad)
  bool driven[kHandJoints] = {};  // has a motor (false: coupled distal joint)
  // the motors
  int actuator[kHandMotors] = {};  // index into ctrl
  int actuated[kHandMotors] = {};  // index into the joints
  double ctrl_lo[kHandMotors] = {}, ctrl_hi[kHandMotors] = {};
  // coupled joints: joint index, the joint it follows, ratio
  struct Coupling {
    int joint = 0, follows = 0;
    double ratio = 0;
  };
  Coupling couplings[kMaxCouplings] = {};
  int ncouplings = 0;
  // base actions at +-1 (free base only)
  double force_max = 0;   // N
  double torque_max = 0;  // N m
};
static_assert(std::is_trivially_copyable_v<HandRig>, "copied to the device as bytes");

BIDEX_HD inline int hand_actions(const HandRig& r) {
  return r.free_base ? kHandActFree : kHandActFixed;
}
BIDEX_HD inline int hand_obs(const HandRig& r) {
  return r.free_base ? kHandObsFree : kHandObsFixed;
}

// World-frame linear velocity at a body's origin and angular velocity, from cvel (about the
// subtree centre of mass of the tree root `root_tree`).
template <class Real>
BIDEX_HD void body_velocity(const sim::WorldRows<Real>& w, int body, int root_tree, Real* lin,
                            Real* ang) {
  const Real* c = w.cvel + 6 * body;
  const Real* com = w.subtree_com + 3 * root_tree;
  const Real* p = w.xpos + 3 * body;
  const Real r[3] = {p[0] - com[0], p[1] - com[1], p[2] - com[2]};
  Real wxr[3];
  math::cross3(wxr, c, r);
  for (int k = 0; k < 3; ++k) {
    ang[k] = c[k];
    lin[k] = c[3 + k] + wxr[k];
  }
}

// Reward points of the original (tasks/README.md): a fingertip point is the distal body's origin
// + 0.02 m along its local z (k: 0 ff, 1 mf, 2 rf, 3 lf, 4 th); the palm point is the palm body's
// origin + 0.08 m along its local z - 0.02 m along its local y.
template <class Real>
BIDEX_HD void tip_point(const HandRig& r, const sim::WorldRows<Real>& w, int k, Real* out) {
  const int b = r.tip_body[k];
  const Real local[3] = {0, 0, Real(0.02)};
  math::frame_point(out, w.xpos + 3 * b, w.xquat + 4 * b, local);
}
template <class Real>
BIDEX_HD void palm_point(const HandRig& r, const sim::WorldRows<Real>& w, Real* out) {
  const int b = r.palm_body;
  const Real local[3] = {0, Real(-0.02), Real(0.08)};
  math::frame_point(out, w.xpos + 3 * b, w.xquat + 4 * b, local);
}
// Sum over the 5 fingertip points of their distance to p (the papers' sum of fingertip distances).
template <class Real>
BIDEX_HD Real tip_distance_sum(const HandRig& r, const sim::WorldRows<Real>& w, const Real* p) {
  Real sum = 0;
  for (int k = 0; k < kTips; ++k) {
    Real t[3];
    tip_point(r, w, k, t);
    sum += math::dist3(t, p);
  }
  return sum;
}

// Two blocks, each reached by one hand (push_block, block_stack): the left hand's fingertips to
// block 1, the right hand's to block 2, and each block's distance to its target position.
template <class Real>
struct TwoBlockReach {
  const Real* b1;  // the blocks' positions
  const Real* b2;
  Real d_left, d_right;  // fingertip distance sums
  Real e1, e2;           // distances to the targets
  // whether a hand strayed `max` or farther from its block (max <= 0: never)
  BIDEX_HD bool strayed(double max) const {
    return max > 0 && (d_left >= Real(max) || d_right >= Real(max));
  }
};
template <class Real>
BIDEX_HD TwoBlockReach<Real> two_block_reach(const HandRig (&hands)[2],
                                             const sim::WorldRows<Real>& w, const int (&body)[2],
                                             const double* target1, const double* target2) {
  TwoBlockReach<Real> r;
  r.b1 = w.xpos + 3 * body[0];
  r.b2 = w.xpos + 3 * body[1];
  r.d_left = tip_distance_sum(hands[1], w, r.b1);
  r.d_right = tip_distance_sum(hands[0], w, r.b2);
  Real t1[3], t2[3];
  for (int k = 0; k < 3; ++k) {
    t1[k] = Real(target1[k]);
    t2[k] = Real(target2[k]);
  }
  r.e1 = math::dist3(r.b1, t1);
  r.e2 = math::dist3(r.b2, t2);
  return r;
}

// One hand's actions (paper order: 20 joints, then base translation 3 and rotation 3 when the
// base is free), already clipped: joint targets l + (a + 1)(u - l) / 2 into ctrl, base force and
// torque into the hand's 6 values of the base_wrench row.
template <class Real>
BIDEX_HD void apply_hand_actions(const HandRig& r, const float* a, const sim::WorldRows<Real>& w) {
  for (int k = 0; k < kHandMotors; ++k) {
    const Real lo = Real(r.ctrl_lo[k]), hi = Real(r.ctrl_hi[k]);
    const Real t = lo + (static_cast<Real>(a[k]) + Real(1)) * Real(0.5) * (hi - lo);
    w.ctrl[r.actuator[k]] = math::clamp(t, lo, hi);  // NaN passes through: the step flags it
  }
  if (r.free_base) {
    Real* f = w.base_wrench + 6 * r.hand;
    for (int k = 0; k < 3; ++k) {
      f[k] = static_cast<Real>(a[kHandMotors + k]) * Real(r.force_max);
      f[3 + k] = static_cast<Real>(a[kHandMotors + 3 + k]) * Real(r.torque_max);
    }
  }
}
// Both hands' actions, the right hand's slice first (20 or 26 values each, by the base).
template <class Real>
BIDEX_HD void apply_two_hand_actions(const HandRig (&hands)[2], const float* a,
                                     const sim::WorldRows<Real>& w) {
  apply_hand_actions(hands[0], a, w);
  apply_hand_actions(hands[1], a + hand_actions(hands[0]), w);
}

// The hand block of the observation (187 values for a fixed base, 199 for a free one); the
// layout is tasks::add_hand_obs.
template <class Real>
BIDEX_HD void observe_hand(const HandRig& r, const sim::WorldRows<Real>& w, const float* actions,
                           float* out) {
  float* o = out;
  for (int j = 0; j < kHandJoints; ++j) {
    const Real q = w.qpos[r.qpos_adr[j]], lo = Real(r.lower[j]), hi = Real(r.upper[j]);
    *o++ = static_cast<float>((2 * q - hi - lo) / (hi - lo));
  }
  for (int j = 0; j < kHandJoints; ++j)
    *o++ = static_cast<float>(Real(0.2) * w.qvel[r.dof_adr[j]]);
  for (int j = 0; j < kHandJoints; ++j) {
    const int d = r.dof_adr[j];
    const Real f = r.driven[j] ? w.qfrc_actuator[d] : w.qfrc_constraint[d];
    *o++ = static_cast<float>(Real(10) * f);
  }
  for (int t = 0; t < kTips; ++t) {
    const int b = r.tip_body[t];
    Real lin[3], ang[3];
    body_velocity(w, b, r.root_tree, lin, ang);
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(w.xpos[3 * b + k]);
    math::put_quat_xyzw(o, w.xquat + 4 * b);
    o += 4;
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(lin[k]);
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(ang[k]);
  }
  for (int t = 0; t < kTips; ++t) {
    for (int k = 0; k < 3; ++k)
      *o++ = static_cast<float>(Real(10) * w.sensordata[r.tip_force_adr[t] + k]);
    for (int k = 0; k < 3; ++k)
      *o++ = static_cast<float>(Real(10) * w.sensordata[r.tip_torque_adr[t] + k]);
  }
  if (r.free_base) {
    const int b = r.root_body;
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(w.xpos[3 * b + k]);
    Real e[3];
    math::euler_xyz(e, w.xquat + 4 * b);
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(e[k]);
  }
  const int na = hand_actions(r);
  for (int k = 0; k < na; ++k) *o++ = actions[k];
}
// Both hand blocks of the observation (right, then left); returns where the task's tail starts.
template <class Real>
BIDEX_HD float* observe_two_hands(const HandRig (&hands)[2], const sim::WorldRows<Real>& w,
                                  const float* actions, float* obs) {
  observe_hand(hands[0], w, actions, obs);
  observe_hand(hands[1], w, actions + hand_actions(hands[0]), obs + hand_obs(hands[0]));
  return obs + hand_obs(hands[0]) + hand_obs(hands[1]);
}

// Joint reset noise of the original: q_j = noise (l_j + (u_j - l_j) r_j), r ~ U(-1, 1), per
// joint, then clamped into the joint range (the original can leave the range).
template <class Real>
BIDEX_HD void sample_joint_noise(const HandRig& r, double noise, SlotRng& rng,
                                 Real (&q)[kHandJoints]) {
  for (int j = 0; j < kHandJoints; ++j) {
    const double u = rng.uniform(-1, 1);
    const double x = noise * (r.lower[j] + (r.upper[j] - r.lower[j]) * u);
    q[j] = static_cast<Real>(math::clamp(x, r.lower[j], r.upper[j]));
  }
}
// Writes joint angles (tree order) into a reset's rows: coupled joints following their joint
// (ratio x), zero joint velocity, motor targets at the new angles.
template <class Real>
BIDEX_HD void set_hand_joints(const HandRig& r, const sim::ResetRows<Real>& rows,
                              const Real (&angles)[kHandJoints]) {
  Real q[kHandJoints];
  for (int j = 0; j < kHandJoints; ++j) q[j] = angles[j];
  for (int i = 0; i < r.ncouplings; ++i) {
    const auto& c = r.couplings[i];
    q[c.joint] = math::clamp(Real(c.ratio) * q[c.follows], Real(r.lower[c.joint]),
                             Real(r.upper[c.joint]));
  }
  for (int j = 0; j < kHandJoints; ++j) {
    rows.qpos[r.qpos_adr[j]] = q[j];
    rows.qvel[r.dof_adr[j]] = 0;
  }
  for (int k = 0; k < kHandMotors; ++k) {
    const Real lo = Real(r.ctrl_lo[k]), hi = Real(r.ctrl_hi[k]);
    rows.ctrl[r.actuator[k]] = math::clamp(q[r.actuated[k]], lo, hi);
  }
}
// The reset noise of both hands, as the original draws it: one sample_joint_noise for the right
// hand's rig, written into both hands (nothing drawn when noise is 0).
template <class Real>
BIDEX_HD void randomise_hand_joints(const HandRig (&hands)[2], double noise, SlotRng& rng,
                                    const sim::ResetRows<Real>& rows) {
  if (noise <= 0) return;
  Real q[kHandJoints];
  sample_joint_noise(hands[0], noise, rng, q);
  set_hand_joints(hands[0], rows, q);
  set_hand_joints(hands[1], rows, q);
}

}  // namespace bidex::tasks
