// The hand half of every task: where each hand's joints, fingertips, palm and base live in the
// compiled scene, and the per-slot functions shared by all tasks: actions -> joint targets and
// base forces, the hand block of the observation, joint resets.
#pragma once

#include <array>
#include <random>
#include <vector>

#include "sim/batch.h"
#include "sim/model.h"
#include "sim/scene.h"
#include "tasks/config_fields.h"

namespace bidex::tasks {

constexpr int kTips = 5;  // ff, mf, rf, lf, th

struct HandRig {
  sim::Side side = sim::Side::kRight;
  int hand = 0;              // index into SimModel::hands() (and the base_wrench row)
  bool free_base = false;
  int root_body = -1;        // forearm: the base
  int root_tree = -1;        // MuJoCo's body_rootid of the hand (origin of cvel)
  int palm_body = -1;
  std::array<int, kTips> tip_body{}, tip_force_adr{}, tip_torque_adr{};
  // the 24 joints, tree order
  std::vector<int> qpos_adr, dof_adr;
  std::vector<double> lower, upper;   // joint range (rad)
  std::vector<bool> driven;           // has a motor (false: coupled distal joint)
  // the 20 motors, tree order
  std::vector<int> actuator;          // index into ctrl
  std::vector<int> actuated;          // index into the 24 joints
  std::vector<double> ctrl_lo, ctrl_hi;
  // coupled joints: joint index, the joint it follows, ratio
  struct Coupling {
    int joint, follows;
    double ratio;
  };
  std::vector<Coupling> couplings;
  // base actions at +-1 (free base only)
  double force_max = 0;   // N
  double torque_max = 0;  // N m
};

// Binds one hand of a compiled scene; throws ModelError if the scene has no such hand.
HandRig bind_hand(const sim::SimModel& model, sim::Side side);
// Both hands (right, left) with their base action scales: action +-1 gives force_scale x 1e5/60 N
// and torque_scale x 1e3/60 N m.
void bind_two_hands(const sim::SimModel& model, double force_scale, double torque_scale,
                    HandRig (&hands)[2]);
// Both hands into a task's scene at their mounts.
void add_two_hands(sim::SceneBuilder& sb, const sim::HandSpec& right_hand, const HandPose& right,
                   const HandPose& left, sim::Base base);

// Reward points of the original (tasks/README.md): a fingertip point is the distal body's origin
// + 0.02 m along its local z (k: 0 ff, 1 mf, 2 rf, 3 lf, 4 th); the palm point is the palm body's
// origin + 0.08 m along its local z - 0.02 m along its local y.
void tip_point(const HandRig& rig, const sim::SlotView& v, int k, double* out);
void palm_point(const HandRig& rig, const sim::SlotView& v, double* out);
// Sum over the 5 fingertip points of their distance to p (the papers' sum of fingertip distances).
double tip_distance_sum(const HandRig& rig, const sim::SlotView& v, const double* p);

// One hand's actions (paper order: 20 joints, then base translation 3 and rotation 3 when the
// base is free), already clipped: joint targets l + (a + 1)(u - l) / 2 into ctrl, base force and
// torque into the hand's 6 values of the base_wrench row.
void apply_hand_actions(const HandRig& rig, const float* a, double* ctrl, double* wrench);

// Both hands' actions, the right hand's slice first (20 or 26 values each, by the base).
void apply_two_hand_actions(const HandRig (&hands)[2], const float* a, double* ctrl,
                            double* wrench);
// Both hand blocks of the observation (right, then left); returns where the task's tail starts.
float* observe_two_hands(const HandRig (&hands)[2], const sim::SlotView& v, const float* actions,
                         float* obs);

// The hand block of the observation (187 values for a fixed base, 199 for a free one); the
// layout is tasks::add_hand_obs.
void observe_hand(const HandRig& rig, const sim::SlotView& v, const float* actions, float* out);

// World-frame linear velocity at a body's origin and angular velocity, from the batch's cvel.
void body_velocity(const sim::SlotView& v, int body, int root_tree, double* lin, double* ang);

// Joint reset noise of the original: q_j = noise (l_j + (u_j - l_j) r_j), r ~ U(-1, 1), per
// joint, then clamped into the joint range (the original can leave the range). 24 values.
std::vector<double> sample_joint_noise(const HandRig& rig, double noise, std::mt19937_64& rng);
// Writes joint angles (24, tree order) into the slot's MuJoCo state, coupled joints following
// their joint (ratio x), zero joint velocity, motor targets at the new angles (data->ctrl and the
// batch's ctrl row).
void set_hand_joints(const HandRig& rig, mjData* data, double* ctrl_row, std::vector<double> q);
// The reset noise of both hands, as the original draws it: one sample_joint_noise for the right
// hand's rig, written into both hands (nothing drawn when noise is 0).
void randomise_hand_joints(const HandRig (&hands)[2], double noise, std::mt19937_64& rng,
                           mjData* data, double* ctrl_row);

}  // namespace bidex::tasks
