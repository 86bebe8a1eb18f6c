#include "tasks/hands.h"

#include <algorithm>
#include <cmath>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "tasks/math.h"
#include "tasks/spec.h"

namespace bidex::tasks {

HandRig bind_hand(const sim::SimModel& model, sim::Side side) {
  const mjModel* m = model.mj();
  const auto& hands = model.hands();
  HandRig r;
  const sim::HandIndex* hi = nullptr;
  for (size_t h = 0; h < hands.size(); ++h)
    if (hands[h].side == side) {
      hi = &hands[h];
      r.hand = static_cast<int>(h);
    }
  if (!hi) throw ModelError(std::string("the scene has no ") + sim::side_name(side) + " hand");
  auto expect = [&](const char* what, size_t got, int want) {
    if (got != static_cast<size_t>(want))
      throw ModelError("hand " + hi->prefix + ": expected " + std::to_string(want) + " " + what +
                       ", got " + std::to_string(got));
  };
  expect("fingertip sensors", hi->tip_bodies.size(), kTips);
  expect("joints", hi->joints.size(), kHandJoints);
  expect("motors", hi->actuators.size(), kHandMotors);
  r.free_base = hi->free_base;
  r.root_body = hi->root_body;
  r.root_tree = m->body_rootid[hi->root_body];
  r.palm_body = mj_name2id(m, mjOBJ_BODY, (hi->prefix + "palm").c_str());
  if (r.palm_body < 0) throw ModelError("hand " + hi->prefix + ": no body named palm");
  for (int t = 0; t < kTips; ++t) {
    r.tip_body[t] = hi->tip_bodies[t];
    r.tip_force_adr[t] = hi->tip_force_adr[t];
    r.tip_torque_adr[t] = hi->tip_torque_adr[t];
  }
  for (int j = 0; j < kHandJoints; ++j) {
    r.qpos_adr[j] = hi->qpos_adr[j];
    r.dof_adr[j] = hi->dof_adr[j];
    r.lower[j] = m->jnt_range[2 * hi->joints[j]];
    r.upper[j] = m->jnt_range[2 * hi->joints[j] + 1];
  }
  for (int a = 0; a < kHandMotors; ++a) {
    const int id = hi->actuators[a];
    r.actuator[a] = id;
    r.actuated[a] = hi->actuated[a];
    r.driven[hi->actuated[a]] = true;
    r.ctrl_lo[a] = m->actuator_ctrlrange[2 * id];
    r.ctrl_hi[a] = m->actuator_ctrlrange[2 * id + 1];
  }
  // couplings are joint equalities joint1 = ratio * joint2 between two of this hand's joints
  auto local = [&](int jnt) {
    for (int j = 0; j < kHandJoints; ++j)
      if (hi->joints[j] == jnt) return j;
    return -1;
  };
  for (int e = 0; e < m->neq; ++e) {
    if (m->eq_type[e] != mjEQ_JOINT) continue;
    int a = local(m->eq_obj1id[e]), b = local(m->eq_obj2id[e]);
    if (a < 0 || b < 0) continue;
    if (r.ncouplings == kMaxCouplings)
      throw ModelError("hand " + hi->prefix + ": more than " + std::to_string(kMaxCouplings) +
                       " coupled joints");
    r.couplings[r.ncouplings++] = {a, b, m->eq_data[mjNEQDATA * e + 1]};
  }
  return r;
}

void bind_two_hands(const sim::SimModel& model, double force_scale, double torque_scale,
                    HandRig (&hands)[2]) {
  hands[0] = bind_hand(model, sim::Side::kRight);
  hands[1] = bind_hand(model, sim::Side::kLeft);
  for (auto& h : hands) {
    h.force_max = force_scale * 1e5 / 60.0;
    h.torque_max = torque_scale * 1e3 / 60.0;
  }
}

void add_two_hands(sim::SceneBuilder& sb, const sim::HandSpec& right_hand, const HandPose& right,
                   const HandPose& left, sim::Base base, bool hands_collide) {
  auto pose = [](const HandPose& h) { return sim::Pose::rpy(h.pos, h.rpy[0], h.rpy[1], h.rpy[2]); };
  sb.set_hand_hand_contacts(hands_collide);
  sb.add_hand(right_hand, {sim::Side::kRight, pose(right), base});
  sb.add_hand(right_hand, {sim::Side::kLeft, pose(left), base});
}

void randomise_hand_joints(const HandRig (&hands)[2], double noise, TaskSlot& t) {
  randomise_hand_joints(hands, noise, *t.rng, reset_rows(t));
  end_reset(t);
}

}  // namespace bidex::tasks
