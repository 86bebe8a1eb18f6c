// re_orientation: Re-Orientation (the original's ShadowHandReOrientation), on free bases as the
// paper specifies; defaults in re_orientation.yaml, decisions in README.md, stages in
// re_orientation_body.h. Each hand holds a cube and turns it to the goal orientation; both
// reached at once -> bonus and new goals.
#pragma once

#include "tasks/manipulation_family.h"
#include "tasks/re_orientation/re_orientation_body.h"
#include "tasks/body_task.h"

namespace bidex::tasks {

struct ReOrientationParams {
  manip::CommonParams common;
  double edge = 0.05, density = 1000, friction = 1;
  sim::Vec3 start[2]{}, goal[2]{};
  // reset
  double object_position_noise = 0.01;
  bool random_object_rotation = true, random_goal_rotation = true;
  double hand_dof_noise = 0.2;
  // reward: dist_scale (d1 + d2) + rot_scale / (theta_i + rot_eps) + action_penalty sum(a^2)
  double dist_scale = -10, rot_scale = 1, rot_eps = 0.1, action_penalty = -0.0002;
  double goal_bonus = 500, rotation_tolerance = 0.1, rotation_progress = 0;
  bool each_goal = false;  // goal_mode: "both" (false) or "each" (true), README
  // curriculum (README "Learning"; ReOrientationProgram says what the values do)
  bool curriculum = false;
  double curriculum_start = 0, curriculum_up = 0.02, curriculum_down = 0.05;
  double drop_height = 0.2;
};

BIDEX_STAGE_BODIES(ReOrientation, ReOrientationProgram, re_orientation_);

class ReOrientation : public BodyTask<manip::ManipTask, ReOrientationBodies> {
 public:
  ReOrientation(const TaskSpec& spec, ReOrientationParams p);
  sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                          const sim::PhysicsOptions& physics) const override;
  void bind(const sim::SimModel& model) override;
  bool curriculum() const override { return p_.curriculum; }

 private:
  ReOrientationParams p_;
};

}  // namespace bidex::tasks
