// bottle_cap: Open Bottle Cap (the original's ShadowHandBottleCap); defaults in bottle_cap.yaml,
// decisions in README.md, stages in bottle_cap_body.h. One hand holds the bottle, the other
// pulls its cap off along the bottle's axis (a slide joint with a limit, friction and damping,
// and a free twist).
#pragma once

#include <string>

#include "tasks/bottle_cap/bottle_cap_body.h"
#include "tasks/manipulation_family.h"
#include "tasks/body_task.h"

namespace bidex::tasks {

struct BottleCapParams {
  manip::CommonParams common;
  manip::TableParams table;
  sim::Vec3 bottle_start{}, bottle_rpy{};
  double density = 500, friction = 1;
  double cap_travel = 0.064;      // slide range [0, travel] (m)
  double cap_frictionloss = 0.5;  // N: the pull the cap needs before it moves
  double cap_damping = 1;         // N s/m
  double twist_damping = 0.001;   // N m s/rad
  double cap_point = 0.15;        // c = bottle origin + R (0, 0, cap_point)
  // reward: offset - d_right - d_left + open_scale d_open; the variant read ("original",
  // "paper"; tasks/README.md, "Rewards")
  std::string reward_variant;
  double offset = 0.2, open_scale = 30;
  double goal_gate = 0;           // > 0: the opening term only while d_right <= it
  double success_opening = 0.03;  // m
  // termination
  double cap_drop_height = 0.5;   // z(c) at or below
  double max_right_palm = 0.5;    // |c - palm_R| at or above
  double max_left_palm = 0.2;     // |b - palm_L| at or above
};

BIDEX_STAGE_BODIES(BottleCap, BottleCapProgram, bottle_cap_);

class BottleCap : public BodyTask<manip::ManipTask, BottleCapBodies> {
 public:
  BottleCap(const TaskSpec& spec, BottleCapParams p);
  const BottleCapParams& params() const { return p_; }
  sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                          const sim::PhysicsOptions& physics) const override;
  void bind(const sim::SimModel& model) override;

 private:
  BottleCapParams p_;
};

}  // namespace bidex::tasks
