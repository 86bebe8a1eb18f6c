// The host half of the hands: binding a HandRig to a compiled scene, adding the hands to a
// scene, and the per-slot hand functions of tasks/hand_body.h over a TaskSlot's double rows
// (a SlotView and the slot's mjData) for task code that is not a stage body.
#pragma once

#include "sim/batch.h"
#include "sim/model.h"
#include "sim/scene.h"
#include "tasks/config_fields.h"
#include "tasks/hand_body.h"
#include "tasks/task.h"

namespace bidex::tasks {

// Binds one hand of a compiled scene; throws ModelError if the scene has no such hand.
HandRig bind_hand(const sim::SimModel& model, sim::Side side);
// Both hands (right, left) with their base action scales: action +-1 gives force_scale x 1e5/60 N
// and torque_scale x 1e3/60 N m.
void bind_two_hands(const sim::SimModel& model, double force_scale, double torque_scale,
                    HandRig (&hands)[2]);
// Both hands into a task's scene at their mounts.
void add_two_hands(sim::SceneBuilder& sb, const sim::HandSpec& right_hand, const HandPose& right,
                   const HandPose& left, sim::Base base, bool hands_collide);

// tasks/hand_body.h's functions over a slot's batch rows.
inline void tip_point(const HandRig& r, const sim::SlotView& v, int k, double* out) {
  tip_point(r, world_rows(v), k, out);
}
inline void palm_point(const HandRig& r, const sim::SlotView& v, double* out) {
  palm_point(r, world_rows(v), out);
}
inline double tip_distance_sum(const HandRig& r, const sim::SlotView& v, const double* p) {
  return tip_distance_sum(r, world_rows(v), p);
}
// The reset noise of both hands into a slot (its MuJoCo data and the batch's ctrl row).
void randomise_hand_joints(const HandRig (&hands)[2], double noise, TaskSlot& t);

}  // namespace bidex::tasks
