// block_stack: Stack Block (the original's ShadowHandBlockStack); defaults in block_stack.yaml,
// decisions in README.md. The left hand's block 1 goes on top of the right hand's block 2.
#include <cmath>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/yaml.h"
#include "tasks/manipulation_family.h"
#include "tasks/math.h"
#include "tasks/registry.h"

namespace bidex::tasks {

namespace {

struct StackParams {
  manip::CommonParams common;
  manip::TableParams table;
  manip::BlockPair blocks;  // block1 (left hand's, on top), block2 (right hand's); place = targets
  // reward: offset - d_left - d_right + goal_scale (goal_offset - d_target) [+ stack bonus]
  double offset = 1.5, goal_scale = 2, goal_offset = 0.24;
  double goal_gate = 0;               // > 0: the goal term only while both hands' sums < it
  double stack_bonus_scale = 0;       // the original's 50 (0: the paper's formula)
  double stack_tolerance = 0.07;      // each block this close to its target
  double height_tolerance = 0.03;     // |z(target1) - z(block1)| below it
  double max_tip_distance = 0.75;
};

StackParams load(const std::string& file) {
  const YamlView root = YamlView::load_file(file);
  root.allow_keys({"episode_length", "hands", "base", "table", "blocks", "reward", "termination"});
  StackParams p;
  p.common = manip::load_common(root, file);
  p.table = manip::load_table(root.child("table"));
  p.blocks = manip::load_block_pair(root.child("blocks"), "target");
  {
    auto r = root.child("reward");
    r.allow_keys({"offset", "goal_scale", "goal_offset", "goal_gate", "stack_bonus_scale",
                  "stack_tolerance", "height_tolerance"});
    p.offset = read_number(r, "offset", -100, 100, "an offset in [-100, 100]");
    p.goal_scale = read_number(r, "goal_scale", 0, 1000, "a scale in [0, 1000]");
    p.goal_offset = read_number(r, "goal_offset", -10, 10, "a distance in [-10, 10] m");
    p.goal_gate = read_number(r, "goal_gate", 0, 100, "a fingertip distance sum in [0, 100] m (0: off)");
    p.stack_bonus_scale = read_number(r, "stack_bonus_scale", 0, 1e4, "a scale in [0, 1e4]");
    p.stack_tolerance = read_number(r, "stack_tolerance", 0, 1, "a distance in [0, 1] m");
    p.height_tolerance = read_number(r, "height_tolerance", 0, 1, "a distance in [0, 1] m");
  }
  {
    auto t = root.child("termination");
    t.allow_keys({"max_tip_distance"});
    p.max_tip_distance =
        read_number(t, "max_tip_distance", 0, 100, "a fingertip distance sum in [0, 100] m (0: off)");
  }
  return p;
}

class BlockStack : public manip::ManipTask {
 public:
  BlockStack(const TaskSpec& spec, StackParams p) : ManipTask(spec, p.common), p_(std::move(p)) {}

  sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                          const sim::PhysicsOptions& physics) const override {
    sim::SceneBuilder sb = scene_with_hands(right_hand, physics);
    sb.add_object(manip::table("table", p_.table));
    const auto& b = p_.blocks;
    const sim::Quat q = manip::quat_rpy(b.rpy);
    for (int i = 0; i < 2; ++i) {
      auto o = manip::cube("block" + std::to_string(i + 1), b.edge, b.density, b.friction,
                           b.start[i], q);
      if (i == 1) o.rgba = {0.25, 0.45, 0.85, 1};
      sb.add_object(o);
    }
    sb.add_object(manip::marker_box("goal", b.edge / 2, b.place[0], q, {0.85, 0.35, 0.25, 0.3}));
    return sb;
  }

  void bind(const sim::SimModel& model) override {
    bind_hands(model);
    for (int i = 0; i < 2; ++i) {
      const auto& o = manip::object_index(model, spec().id, "block" + std::to_string(i + 1));
      body_[i] = o.body;
      tree_[i] = model.mj()->body_rootid[o.body];
    }
    t_offset_ = spec().term_index("offset");
    t_left_ = spec().term_index("left_hand");
    t_right_ = spec().term_index("right_hand");
    t_goal_ = spec().term_index("goal");
    t_stack_ = spec().term_index("stack_bonus");
  }

  void reset(TaskSlot& t) const override {
    // blocks at their start poses (the simulation's reset); the goal is block 1's target, in
    // the blocks' start orientation
    const sim::Quat q = manip::quat_rpy(p_.blocks.rpy);
    for (int k = 0; k < 3; ++k) t.task->goal[0][k] = p_.blocks.place[0][k];
    for (int k = 0; k < 4; ++k) t.task->goal[0][3 + k] = q[k];
  }

  bool evaluate(TaskSlot& t, double* terms) const override {
    const auto& v = t.state;
    const double* b1 = v.xpos + 3 * body_[0];
    const double* b2 = v.xpos + 3 * body_[1];
    const double d_left = tip_distance_sum(hands_[1], v, b1);
    const double d_right = tip_distance_sum(hands_[0], v, b2);
    const double e1 = math::dist3(b1, p_.blocks.place[0].data());
    const double e2 = math::dist3(b2, p_.blocks.place[1].data());
    terms[t_offset_] = p_.offset;
    terms[t_left_] = -d_left;
    terms[t_right_] = -d_right;
    const bool gate_open = p_.goal_gate <= 0 || (d_left < p_.goal_gate && d_right < p_.goal_gate);
    terms[t_goal_] = gate_open ? p_.goal_scale * (p_.goal_offset - (e1 + e2)) : 0.0;
    const double dz = std::abs(p_.blocks.place[0][2] - b1[2]);
    const bool placed = e1 < p_.stack_tolerance && e2 < p_.stack_tolerance;
    if (placed) terms[t_stack_] = p_.stack_bonus_scale * (0.05 - dz);
    if (placed && dz < p_.height_tolerance) t.task->success = true;
    return p_.max_tip_distance > 0 &&
           (d_left >= p_.max_tip_distance || d_right >= p_.max_tip_distance);
  }

  void observe(const TaskSlot& t, float* obs) const override {
    float* o = observe_hands(t, obs);
    observe_object(t.state, body_[0], tree_[0], o);
    observe_goal(t.task->goal[0].data(), t.state.xquat + 4 * body_[0], o + 13);
    manip::put3(o + 24, t.state.xpos + 3 * body_[0]);
    manip::put3(o + 27, t.state.xpos + 3 * body_[1]);
  }

 private:
  StackParams p_;
  int body_[2] = {-1, -1}, tree_[2] = {-1, -1};
  int t_offset_ = -1, t_left_ = -1, t_right_ = -1, t_goal_ = -1, t_stack_ = -1;
};

TaskSpec make_spec() {
  TaskSpec s = manip::spec_with_hands(
      "block_stack", "Stack Block", "ShadowHandBlockStack", HumanAge{22, 28, "22-28", false},
      Difficulty::kMedium, "Stacks at least 2 blocks in any trial.", 250);
  add_object_obs(s.obs, "block1", "block 1 (the left hand's, the top one)");
  add_goal_obs(s.obs, "goal", "block 1's target, on top of block 2's target");
  s.obs.add("block1.pos", 3, "block 1 position (m), as the paper's table repeats it");
  s.obs.add("block2.pos", 3, "block 2 (the right hand's, the bottom one) position (m)");
  s.agents = agents_per_hand(s.obs, s.act);
  s.reward_terms = {
      {"offset", "reward.offset (the paper's 1.5)"},
      {"left_hand", "-d_left: sum of the left fingertips' distances to block 1 (m)"},
      {"right_hand", "-d_right: sum of the right fingertips' distances to block 2 (m)"},
      {"goal", "goal_scale (goal_offset - d_target), d_target = |b1 - t1| + |b2 - t2| (m)"},
      {"stack_bonus", "stack_bonus_scale (0.05 - |z(t1) - z(b1)|) while both blocks are within "
                      "stack_tolerance of their targets (0 by default: not in the paper)"},
  };
  return s;
}

}  // namespace

const TaskSpec& block_stack_spec() {
  static const TaskSpec spec = make_spec();
  return spec;
}

std::unique_ptr<Task> make_block_stack(const std::string& config_file) {
  return std::make_unique<BlockStack>(block_stack_spec(), load(config_file));
}

}  // namespace bidex::tasks
