// The table family's stage bodies (tasks/README.md): TableProgram and the four stages over one
// world's rows, for host and device. TableTask (tasks/table_family.h) builds the program in
// bind() and calls the bodies with the CPU batch's double rows.
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

enum class TableKind { kSwingCup, kScissors, kPen, kSwitch, kPourWater };

// Geometry of the objects (metres, in each body's own frame; tasks/*/README.md draws them).
namespace table_geom {
// swing_cup: handle centres in the cup frame (right, left)
constexpr double kCupHandleX = 0.075, kCupHandleZ = 0.07;
// scissors: the moving half's hinge sits at its body origin, turned by kScissorsRest about z
// relative to the root at joint angle 0 (closed at -kScissorsRest); handle centres
constexpr double kScissorsRest = 0.5969, kScissorsLift = 0.008;
constexpr double kScissorsHandleX = 0.15, kScissorsHandleY = 0.045;
constexpr double kScissorsLower = -0.5969, kScissorsUpper = 0.4;
// pen: cap body at +x of the pen body; grip points on each
constexpr double kPenCapX = 0.03, kPenCapPoint = 0.06, kPenBodyPoint = -0.09, kPenTravel = 0.492;
// switch: rocker hinge above the root, tilted by kSwitchTilt at 0; press point on the rocker
constexpr double kSwitchHingeZ = 0.12, kSwitchTilt = 0.27925, kSwitchOn = 0.5585;
constexpr double kSwitchPressX = 0.04, kSwitchPressZ = 0.008;
constexpr double kSwitchArmature = 0.005;  // kg m^2 on each rocker hinge (README)
// pour_water: kettle handle and spout in the kettle frame; bucket opening in the bucket frame
constexpr double kKettleHandleX = 0.15, kKettleHandleZ = 0.08;
constexpr double kSpoutX = -0.2, kSpoutZ = 0.13;
constexpr double kBucketTop = 0.15;
}  // namespace table_geom

struct TableProgram {
  HandRig hands[2];  // right, left
  TableKind kind = TableKind::kSwingCup;
  // root, moving part or second object, switch 2's rocker, switch 2
  int body[4] = {-1, -1, -1, -1};
  int obs_body = -1, root_tree = -1;  // the object block's body and its tree root
  int compared_body = -1;             // the body whose orientation the goal block compares
  int joint_qpos[2] = {-1, -1}, joint_dof[2] = {-1, -1};
  // the two reward points (right hand's, left hand's): a point fixed in a body's frame
  int point_body[2] = {-1, -1};
  double point_local[2][3] = {};
  // the goal pose: swing_cup, pour_water: orientation goal_quat in the world (swing_cup's
  // position goal_at; pour_water's the left point); scissors, pen, switch: the frame at goal_at,
  // turned by goal_quat, of body[0]
  double goal_at[3] = {}, goal_quat[4] = {1, 0, 0, 0};
  // reset
  double hand_dof_noise = 0, reset_angle = 0;
  // reward (TableParams)
  double offset = 0, gate = 0, goal_scale = 0, goal_offset = 0, rot_eps = 0, reach_scale = 0;
  double target_angle = 0, success = 0;
  double drop_height = 0, max_reach = 0;
  // pour_water: lift_scale x min(max(z - lift_from, 0), lift_max), z the kettle's height
  double lift_scale = 0, lift_max = 0, lift_from = 0;
  int t_offset = -1, t_right = -1, t_left = -1, t_lift = -1, t_goal = -1;
};
static_assert(std::is_trivially_copyable_v<TableProgram>, "copied to the device as bytes");

// The pose of a child frame at `local` (position) and `lq` (orientation) under (pos, quat).
template <class Real>
BIDEX_HD void table_child_frame(const Real* pos, const Real* quat, const double* local,
                                const double* lq, Real* out_pos, Real* out_quat) {
  Real l[3], q[4];
  for (int k = 0; k < 3; ++k) l[k] = Real(local[k]);
  for (int k = 0; k < 4; ++k) q[k] = Real(lq[k]);
  math::frame_point(out_pos, pos, quat, l);
  math::mul_quat(out_quat, quat, q);
}

// A point fixed in body b's frame, in the world.
template <class Real>
BIDEX_HD void table_body_point(const sim::WorldRows<Real>& w, int b, const double* local,
                               Real* out) {
  const Real l[3] = {Real(local[0]), Real(local[1]), Real(local[2])};
  math::frame_point(out, w.xpos + 3 * b, w.xquat + 4 * b, l);
}

// The two reward points (world): the right hand's and the left hand's.
template <class Real>
BIDEX_HD void table_points(const TableProgram& p, const sim::WorldRows<Real>& w, Real* right,
                           Real* left) {
  table_body_point(w, p.point_body[0], p.point_local[0], right);
  table_body_point(w, p.point_body[1], p.point_local[1], left);
}

// The goal pose (position, (w, x, y, z)) and the orientation compared with it.
template <class Real>
BIDEX_HD void table_goal(const TableProgram& p, const sim::WorldRows<Real>& w, Real* pose,
                         Real* compared) {
  const int b0 = p.body[0];
  switch (p.kind) {
    case TableKind::kSwingCup:
      for (int k = 0; k < 3; ++k) pose[k] = Real(p.goal_at[k]);
      for (int k = 0; k < 4; ++k) pose[3 + k] = Real(p.goal_quat[k]);
      break;
    case TableKind::kPourWater: {
      Real r[3];
      table_points(p, w, r, pose);
      for (int k = 0; k < 4; ++k) pose[3 + k] = Real(p.goal_quat[k]);
      break;
    }
    default:
      table_child_frame(w.xpos + 3 * b0, w.xquat + 4 * b0, p.goal_at, p.goal_quat, pose,
                        pose + 3);
      break;
  }
  for (int k = 0; k < 4; ++k) compared[k] = w.xquat[4 * p.compared_body + k];
}

// The goal term's error: swing_cup the rotation distance (rad), scissors |q - q*| (rad), pen
// the grip-point separation (m), switch the summed press-point distances (m), pour_water the
// spout's distance to the bucket opening (m).
template <class Real>
BIDEX_HD Real table_goal_error(const TableProgram& p, const sim::WorldRows<Real>& w) {
  namespace g = table_geom;
  switch (p.kind) {
    case TableKind::kSwingCup: {
      Real pose[7], q[4];
      table_goal(p, w, pose, q);
      return math::rot_distance(q, pose + 3);
    }
    case TableKind::kScissors:
      return math::abs(w.qpos[p.joint_qpos[0]] - Real(p.target_angle));
    case TableKind::kPen: {
      Real r[3], l[3];
      table_points(p, w, r, l);
      return math::dist3(r, l);
    }
    case TableKind::kSwitch: {
      // each press point against its position with the rocker on
      Real sum = 0;
      const double press[3] = {g::kSwitchPressX, 0, g::kSwitchPressZ};
      for (int i = 0; i < 2; ++i) {
        const int root = i == 0 ? p.body[0] : p.body[3];  // the switch's fixed body
        Real rp[3], rq[4], target[3], now[3];
        table_child_frame(w.xpos + 3 * root, w.xquat + 4 * root, p.goal_at, p.goal_quat, rp,
                          rq);
        const Real pr[3] = {Real(press[0]), Real(press[1]), Real(press[2])};
        math::frame_point(target, rp, rq, pr);
        table_body_point(w, i == 0 ? p.body[1] : p.body[2], press, now);
        sum += math::dist3(now, target);
      }
      return sum;
    }
    case TableKind::kPourWater: {
      const double spout[3] = {g::kSpoutX, 0, g::kSpoutZ};
      Real s[3], r[3], b[3];
      table_body_point(w, p.body[0], spout, s);
      table_points(p, w, r, b);
      return math::dist3(s, b);
    }
  }
  return 0;
}

// Whether the success condition holds, given the goal error e.
template <class Real>
BIDEX_HD bool table_success(const TableProgram& p, const sim::WorldRows<Real>& w, Real e) {
  const Real s = Real(p.success);
  switch (p.kind) {
    case TableKind::kSwingCup: return e < s;
    case TableKind::kScissors: return w.qpos[p.joint_qpos[0]] > s;
    case TableKind::kPen: return e > s;
    case TableKind::kSwitch: return e < s;
    case TableKind::kPourWater: return e < s;
  }
  return false;
}

// New episode: hands at their mounts (joint noise as the original, 0 by default); objects at
// their scene poses (the simulation's reset, water included); joints: the scissors at
// reset.joint_angle, the pen closed, both switches off (the original never reset the switches).
template <class Real>
BIDEX_HD void table_reset(const TableProgram& p, const sim::ResetRows<Real>& r, SlotState&,
                          SlotRng& rng) {
  randomise_hand_joints(p.hands, p.hand_dof_noise, rng, r);
  for (int i = 0; i < 2; ++i)
    if (p.joint_qpos[i] >= 0) {
      r.qpos[p.joint_qpos[i]] = Real(p.kind == TableKind::kScissors ? p.reset_angle : 0.0);
      r.qvel[p.joint_dof[i]] = 0;
    }
}

template <class Real>
BIDEX_HD void table_apply_actions(const TableProgram& p, const float* a,
                                  const sim::WorldRows<Real>& w) {
  apply_two_hand_actions(p.hands, a, w);
}

// The reward terms (reach terms from the fingertip sums, the goal term while both are below
// the gate), success; returns whether the episode terminated.
template <class Real>
BIDEX_HD bool table_evaluate(const TableProgram& p, const sim::WorldRows<Real>& w, SlotState& st,
                             SlotRng&, Real* terms) {
  Real r[3], l[3];
  table_points(p, w, r, l);
  const Real sr = tip_distance_sum(p.hands[0], w, r), sl = tip_distance_sum(p.hands[1], w, l);
  const bool near = sr < Real(p.gate) && sl < Real(p.gate);
  const Real e = table_goal_error(p, w);
  const Real scale = Real(p.goal_scale), off = Real(p.goal_offset);
  if (p.t_offset >= 0) terms[p.t_offset] = Real(p.offset);
  bool end = false;
  if (p.kind == TableKind::kPen) {
    terms[p.t_right] = math::exp(-Real(p.reach_scale) * sr);
    terms[p.t_left] = math::exp(-Real(p.reach_scale) * sl);
  } else {
    terms[p.t_right] = -sr;
    terms[p.t_left] = -sl;
  }
  switch (p.kind) {
    case TableKind::kSwingCup:
      terms[p.t_goal] = near ? scale / (e + Real(p.rot_eps)) - off : Real(0);
      end = w.xpos[3 * p.body[0] + 2] <= Real(p.drop_height);
      break;
    case TableKind::kScissors:
      terms[p.t_goal] = near ? scale * (off - e) : Real(0);
      end = sr >= Real(p.max_reach) || sl >= Real(p.max_reach);
      break;
    case TableKind::kPen:
      terms[p.t_goal] = near ? scale * e - off : Real(0);
      end = sr >= Real(p.max_reach) || sl >= Real(p.max_reach);
      break;
    case TableKind::kSwitch:
      terms[p.t_goal] = scale * (off - e);
      break;
    case TableKind::kPourWater: {
      const Real h = math::min(math::max(w.xpos[3 * p.body[0] + 2] - Real(p.lift_from), Real(0)),
                               Real(p.lift_max));
      terms[p.t_lift] = near ? Real(p.lift_scale) * h : Real(0);
      terms[p.t_goal] = near ? scale * (off - e) : Real(0);
      end = l[2] <= Real(p.drop_height);
      break;
    }
  }
  if (table_success(p, w, e)) st.success = true;
  return end;
}

// Both hand blocks, the object block, the goal block, the two reward points (the paper's
// order: the right hand's point first, except the pen: body, then cap).
template <class Real>
BIDEX_HD void table_observe(const TableProgram& p, const sim::WorldRows<Real>& w,
                            const SlotState& st, float* obs) {
  float* o = observe_two_hands(p.hands, w, st.action.data(), obs);
  observe_object(w, p.obs_body, p.root_tree, o);
  Real pose[7], q[4];
  table_goal(p, w, pose, q);
  observe_goal(pose, q, o + 13);
  Real r[3], l[3];
  table_points(p, w, r, l);
  const bool pen = p.kind == TableKind::kPen;
  math::put_vec3(o + 24, pen ? l : r);
  math::put_vec3(o + 27, pen ? r : l);
}

}  // namespace bidex::tasks
