// push_block: Push Block (the original's ShadowHandPushBlock); defaults in push_block.yaml,
// decisions in README.md, stages in push_block_body.h. Each hand pushes its own block to its
// own goal on the table.
#pragma once

#include "tasks/manipulation_family.h"
#include "tasks/push_block/push_block_body.h"
#include "tasks/body_task.h"

namespace bidex::tasks {

struct PushBlockParams {
  manip::CommonParams common;
  manip::TableParams table;
  manip::BlockPair blocks;  // block1 (left hand's), block2 (right hand's); place = goals
  // reward: offset - d_left - d_right + goal_scale (goal_offset - d_target)
  double offset = 2, goal_scale = 5, goal_offset = 0.8;
  double success_tolerance = 0.1;         // each block this close to its goal
  double max_tip_distance = 1.2;          // a hand's fingertip sum this far ends the episode
};

BIDEX_STAGE_BODIES(PushBlock, PushBlockProgram, push_block_);

class PushBlock : public BodyTask<manip::ManipTask, PushBlockBodies> {
 public:
  PushBlock(const TaskSpec& spec, PushBlockParams p);
  sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                          const sim::PhysicsOptions& physics) const override;
  void bind(const sim::SimModel& model) override;

 private:
  PushBlockParams p_;
};

}  // namespace bidex::tasks
