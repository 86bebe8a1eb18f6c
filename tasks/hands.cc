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
  r.side = side;
  const sim::HandIndex* hi = nullptr;
  for (size_t h = 0; h < hands.size(); ++h)
    if (hands[h].side == side) {
      hi = &hands[h];
      r.hand = static_cast<int>(h);
    }
  if (!hi) throw ModelError(std::string("the scene has no ") + sim::side_name(side) + " hand");
  if (hi->tip_bodies.size() != kTips)
    throw ModelError("hand " + hi->prefix + ": expected 5 fingertip sensors, got " +
                     std::to_string(hi->tip_bodies.size()));
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
  const size_t nj = hi->joints.size();
  r.qpos_adr = hi->qpos_adr;
  r.dof_adr = hi->dof_adr;
  r.driven.assign(nj, false);
  for (size_t j = 0; j < nj; ++j) {
    r.lower.push_back(m->jnt_range[2 * hi->joints[j]]);
    r.upper.push_back(m->jnt_range[2 * hi->joints[j] + 1]);
  }
  for (size_t a = 0; a < hi->actuators.size(); ++a) {
    const int id = hi->actuators[a];
    r.actuator.push_back(id);
    r.actuated.push_back(hi->actuated[a]);
    r.driven[hi->actuated[a]] = true;
    r.ctrl_lo.push_back(m->actuator_ctrlrange[2 * id]);
    r.ctrl_hi.push_back(m->actuator_ctrlrange[2 * id + 1]);
  }
  // couplings are joint equalities joint1 = ratio * joint2 between two of this hand's joints
  auto local = [&](int jnt) {
    for (size_t j = 0; j < nj; ++j)
      if (hi->joints[j] == jnt) return static_cast<int>(j);
    return -1;
  };
  for (int e = 0; e < m->neq; ++e) {
    if (m->eq_type[e] != mjEQ_JOINT) continue;
    int a = local(m->eq_obj1id[e]), b = local(m->eq_obj2id[e]);
    if (a >= 0 && b >= 0) r.couplings.push_back({a, b, m->eq_data[mjNEQDATA * e + 1]});
  }
  return r;
}

void apply_hand_actions(const HandRig& r, const float* a, double* ctrl, double* wrench) {
  const size_t na = r.actuator.size();
  for (size_t k = 0; k < na; ++k) {
    const double lo = r.ctrl_lo[k], hi = r.ctrl_hi[k];
    const double t = lo + (static_cast<double>(a[k]) + 1.0) * 0.5 * (hi - lo);
    ctrl[r.actuator[k]] = std::clamp(t, lo, hi);  // NaN passes through: the step flags it
  }
  if (r.free_base) {
    double* w = wrench + 6 * r.hand;
    for (int k = 0; k < 3; ++k) {
      w[k] = a[na + k] * r.force_max;
      w[3 + k] = a[na + 3 + k] * r.torque_max;
    }
  }
}

namespace {
int hand_actions(const HandRig& r) { return r.free_base ? 26 : 20; }
int hand_obs(const HandRig& r) { return r.free_base ? kHandObsFree : kHandObsFixed; }
}  // namespace

void apply_two_hand_actions(const HandRig (&hands)[2], const float* a, double* ctrl,
                            double* wrench) {
  apply_hand_actions(hands[0], a, ctrl, wrench);
  apply_hand_actions(hands[1], a + hand_actions(hands[0]), ctrl, wrench);
}

float* observe_two_hands(const HandRig (&hands)[2], const sim::SlotView& v, const float* actions,
                         float* obs) {
  observe_hand(hands[0], v, actions, obs);
  observe_hand(hands[1], v, actions + hand_actions(hands[0]), obs + hand_obs(hands[0]));
  return obs + hand_obs(hands[0]) + hand_obs(hands[1]);
}

void body_velocity(const sim::SlotView& v, int body, int root_tree, double* lin, double* ang) {
  const double* c = v.cvel + 6 * body;
  const double* com = v.subtree_com + 3 * root_tree;
  const double* p = v.xpos + 3 * body;
  const double r[3] = {p[0] - com[0], p[1] - com[1], p[2] - com[2]};
  double wxr[3];
  math::cross3(wxr, c, r);
  for (int k = 0; k < 3; ++k) {
    ang[k] = c[k];
    lin[k] = c[3 + k] + wxr[k];
  }
}

void tip_point(const HandRig& r, const sim::SlotView& v, int k, double* out) {
  const int b = r.tip_body[k];
  const double local[3] = {0, 0, 0.02};
  math::frame_point(out, v.xpos + 3 * b, v.xquat + 4 * b, local);
}

void palm_point(const HandRig& r, const sim::SlotView& v, double* out) {
  const int b = r.palm_body;
  const double local[3] = {0, -0.02, 0.08};
  math::frame_point(out, v.xpos + 3 * b, v.xquat + 4 * b, local);
}

double tip_distance_sum(const HandRig& r, const sim::SlotView& v, const double* p) {
  double sum = 0;
  for (int k = 0; k < kTips; ++k) {
    double t[3];
    tip_point(r, v, k, t);
    sum += math::dist3(t, p);
  }
  return sum;
}

void observe_hand(const HandRig& r, const sim::SlotView& v, const float* actions, float* out) {
  const size_t nj = r.qpos_adr.size();
  float* o = out;
  for (size_t j = 0; j < nj; ++j) {
    const double q = v.qpos[r.qpos_adr[j]], lo = r.lower[j], hi = r.upper[j];
    *o++ = static_cast<float>((2 * q - hi - lo) / (hi - lo));
  }
  for (size_t j = 0; j < nj; ++j) *o++ = static_cast<float>(0.2 * v.qvel[r.dof_adr[j]]);
  for (size_t j = 0; j < nj; ++j) {
    const int d = r.dof_adr[j];
    const double f = r.driven[j] ? v.qfrc_actuator[d] : v.qfrc_constraint[d];
    *o++ = static_cast<float>(10.0 * f);
  }
  for (int t = 0; t < kTips; ++t) {
    const int b = r.tip_body[t];
    double lin[3], ang[3];
    body_velocity(v, b, r.root_tree, lin, ang);
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(v.xpos[3 * b + k]);
    math::put_quat_xyzw(o, v.xquat + 4 * b);
    o += 4;
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(lin[k]);
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(ang[k]);
  }
  for (int t = 0; t < kTips; ++t) {
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(10.0 * v.sensordata[r.tip_force_adr[t] + k]);
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(10.0 * v.sensordata[r.tip_torque_adr[t] + k]);
  }
  if (r.free_base) {
    const int b = r.root_body;
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(v.xpos[3 * b + k]);
    double e[3];
    math::euler_xyz(e, v.xquat + 4 * b);
    for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(e[k]);
  }
  const size_t na = r.actuator.size() + (r.free_base ? 6 : 0);
  for (size_t k = 0; k < na; ++k) *o++ = actions[k];
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
                   const HandPose& left, sim::Base base) {
  auto pose = [](const HandPose& h) { return sim::Pose::rpy(h.pos, h.rpy[0], h.rpy[1], h.rpy[2]); };
  sb.add_hand(right_hand, {sim::Side::kRight, pose(right), base});
  sb.add_hand(right_hand, {sim::Side::kLeft, pose(left), base});
}

void randomise_hand_joints(const HandRig (&hands)[2], double noise, std::mt19937_64& rng,
                           mjData* data, double* ctrl_row) {
  if (noise <= 0) return;
  const auto q = sample_joint_noise(hands[0], noise, rng);
  for (auto& h : hands) set_hand_joints(h, data, ctrl_row, q);
}

std::vector<double> sample_joint_noise(const HandRig& r, double noise, std::mt19937_64& rng) {
  std::vector<double> q(r.qpos_adr.size(), 0.0);
  for (size_t j = 0; j < q.size(); ++j) {
    const double u = math::uniform(rng, -1, 1);
    const double x = noise * (r.lower[j] + (r.upper[j] - r.lower[j]) * u);
    q[j] = std::clamp(x, r.lower[j], r.upper[j]);
  }
  return q;
}

void set_hand_joints(const HandRig& r, mjData* d, double* ctrl_row, std::vector<double> q) {
  for (auto& c : r.couplings) q[c.joint] = std::clamp(c.ratio * q[c.follows], r.lower[c.joint], r.upper[c.joint]);
  for (size_t j = 0; j < q.size(); ++j) {
    d->qpos[r.qpos_adr[j]] = q[j];
    d->qvel[r.dof_adr[j]] = 0;
  }
  for (size_t k = 0; k < r.actuator.size(); ++k) {
    const double t = std::clamp(q[r.actuated[k]], r.ctrl_lo[k], r.ctrl_hi[k]);
    d->ctrl[r.actuator[k]] = t;
    ctrl_row[r.actuator[k]] = t;
  }
}

}  // namespace bidex::tasks
