// block_stack: Stack Block (the original's ShadowHandBlockStack); defaults in block_stack.yaml,
// decisions in README.md, stages in block_stack_body.h. The left hand's block 1 goes on top of
// the right hand's block 2.
#pragma once

#include <string>

#include "tasks/block_stack/block_stack_body.h"
#include "tasks/manipulation_family.h"
#include "tasks/body_task.h"

namespace bidex::tasks {

struct BlockStackParams {
  manip::CommonParams common;
  manip::TableParams table;
  manip::BlockPair blocks;  // block1 (left hand's, on top), block2 (right hand's); place = targets
  // reward: offset - d_left - d_right + goal_scale (goal_offset - d_target) [+ stack bonus];
  // the variant read ("original", "paper"; tasks/README.md, "Reward variants")
  std::string reward_variant;
  double offset = 1.5, goal_scale = 2, goal_offset = 0.24;
  double goal_gate = 0;               // > 0: the goal term only while both hands' sums < it
  double stack_bonus_scale = 0;       // the original's 50 (0: the paper's formula)
  double stack_tolerance = 0.07;      // each block this close to its target
  double height_tolerance = 0.03;     // |z(target1) - z(block1)| below it
  double max_tip_distance = 0.75;
};

BIDEX_STAGE_BODIES(BlockStack, BlockStackProgram, block_stack_);

class BlockStack : public BodyTask<manip::ManipTask, BlockStackBodies> {
 public:
  BlockStack(const TaskSpec& spec, BlockStackParams p);
  sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                          const sim::PhysicsOptions& physics) const override;
  void bind(const sim::SimModel& model) override;
  const BlockStackParams& params() const { return p_; }

 private:
  BlockStackParams p_;
};

}  // namespace bidex::tasks
