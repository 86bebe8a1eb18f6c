// grasp_and_place: Pull a Ball into Bucket / Grasp & Place (the original's
// ShadowHandGraspAndPlace); defaults in grasp_and_place.yaml, decisions in README.md, stages in
// grasp_and_place_body.h. The right hand takes the bucket, the left hand the block (or ball),
// and the two meet.
#pragma once

#include <string>

#include "tasks/grasp_and_place/grasp_and_place_body.h"
#include "tasks/manipulation_family.h"
#include "tasks/body_task.h"

namespace bidex::tasks {

struct GraspAndPlaceParams {
  manip::CommonParams common;
  manip::TableParams table;
  // bucket: an open box of outer half width, height and wall thickness
  double bucket_half_width = 0.055, bucket_height = 0.154, bucket_wall = 0.005;
  double bucket_density = 500, bucket_friction = 1;
  sim::Vec3 bucket_start{};
  // the object: a cube (edge) or a ball (diameter)
  std::string object_shape = "block";
  double object_size = 0.05, object_density = 500, object_friction = 1;
  sim::Vec3 object_start{}, object_rpy{};
  // reward: exp(-k sum_R(bucket)) + exp(-k sum_L(object)) + place_scale exp(-k |bucket - object|)
  double decay = 10, place_scale = 2;
  double success_tolerance = 0.2;
  double max_tip_distance = 1.5;
};

BIDEX_STAGE_BODIES(GraspAndPlace, GraspAndPlaceProgram, grasp_and_place_);

class GraspAndPlace : public BodyTask<manip::ManipTask, GraspAndPlaceBodies> {
 public:
  GraspAndPlace(const TaskSpec& spec, GraspAndPlaceParams p);
  sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                          const sim::PhysicsOptions& physics) const override;
  void bind(const sim::SimModel& model) override;

 private:
  GraspAndPlaceParams p_;
};

}  // namespace bidex::tasks
