// push_block: Push Block (the original's ShadowHandPushBlock); defaults in push_block.yaml,
// decisions in README.md. Each hand pushes its own block to its own goal on the table.
#include <cmath>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/yaml.h"
#include "tasks/manipulation_family.h"
#include "tasks/math.h"
#include "tasks/registry.h"

namespace bidex::tasks {

namespace {

struct PushParams {
  manip::CommonParams common;
  manip::TableParams table;
  manip::BlockPair blocks;  // block1 (left hand's), block2 (right hand's); place = goals
  // reward: offset - d_left - d_right + goal_scale (goal_offset - d_target)
  double offset = 2, goal_scale = 5, goal_offset = 0.8;
  double success_tolerance = 0.1;         // each block this close to its goal
  double max_tip_distance = 1.2;          // a hand's fingertip sum this far ends the episode
};

PushParams load(const std::string& file) {
  const YamlView root = YamlView::load_file(file);
  root.allow_keys({"episode_length", "hands", "base", "table", "blocks", "reward", "termination"});
  PushParams p;
  p.common = manip::load_common(root, file);
  p.table = manip::load_table(root.child("table"));
  p.blocks = manip::load_block_pair(root.child("blocks"), "goal");
  {
    auto r = root.child("reward");
    r.allow_keys({"offset", "goal_scale", "goal_offset", "success_tolerance"});
    p.offset = read_number(r, "offset", -100, 100, "an offset in [-100, 100]");
    p.goal_scale = read_number(r, "goal_scale", 0, 1000, "a scale in [0, 1000]");
    p.goal_offset = read_number(r, "goal_offset", -10, 10, "a distance in [-10, 10] m");
    p.success_tolerance = read_number(r, "success_tolerance", 0, 10, "a distance in [0, 10] m");
  }
  {
    auto t = root.child("termination");
    t.allow_keys({"max_tip_distance"});
    p.max_tip_distance =
        read_number(t, "max_tip_distance", 0, 100, "a fingertip distance sum in [0, 100] m (0: off)");
  }
  return p;
}

class PushBlock : public manip::ManipTask {
 public:
  PushBlock(const TaskSpec& spec, PushParams p) : ManipTask(spec, p.common), p_(std::move(p)) {}

  sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                          const sim::PhysicsOptions& physics) const override {
    sim::SceneBuilder sb = scene_with_hands(right_hand, physics);
    sb.add_object(manip::table("table", p_.table));
    const sim::Quat q = manip::quat_rpy(p_.blocks.rpy);
    for (int i = 0; i < 2; ++i) {
      const std::string n = std::to_string(i + 1);
      const auto& b = p_.blocks;
      auto o = manip::cube("block" + n, b.edge, b.density, b.friction, b.start[i], q);
      if (i == 1) o.rgba = {0.25, 0.45, 0.85, 1};
      sb.add_object(o);
      sb.add_object(manip::marker_box("goal" + n, p_.blocks.edge / 2, p_.blocks.place[i], q,
                                      {o.rgba[0], o.rgba[1], o.rgba[2], 0.3}));
    }
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
  }

  void reset(TaskSlot& t) const override {
    // blocks back at their start poses (the simulation's reset); goals fixed
    for (int i = 0; i < 2; ++i) {
      for (int k = 0; k < 3; ++k) t.task->goal[i][k] = p_.blocks.place[i][k];
      const sim::Quat q = manip::quat_rpy(p_.blocks.rpy);
      for (int k = 0; k < 4; ++k) t.task->goal[i][3 + k] = q[k];
    }
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
    terms[t_goal_] = p_.goal_scale * (p_.goal_offset - (e1 + e2));
    if (e1 <= p_.success_tolerance && e2 <= p_.success_tolerance) t.task->success = true;
    return p_.max_tip_distance > 0 &&
           (d_left >= p_.max_tip_distance || d_right >= p_.max_tip_distance);
  }

  void observe(const TaskSlot& t, float* obs) const override {
    float* o = observe_hands(t, obs);
    observe_object(t.state, body_[0], tree_[0], o);
    manip::put3(o + 13, t.state.xpos + 3 * body_[0]);
    manip::put3(o + 16, t.state.xpos + 3 * body_[1]);
  }

 private:
  PushParams p_;
  int body_[2] = {-1, -1}, tree_[2] = {-1, -1};
  int t_offset_ = -1, t_left_ = -1, t_right_ = -1, t_goal_ = -1;
};

TaskSpec make_spec() {
  TaskSpec s = manip::spec_with_hands(
      "push_block", "Push Block", "ShadowHandPushBlock", HumanAge{5, 6, "5-6", false},
      Difficulty::kEasy,
      "Extends one or both arms forward and touches the block with either hand.", 125);
  add_object_obs(s.obs, "block1", "block 1 (the left hand's)");
  s.obs.add("block1.pos", 3, "block 1 position (m), as the paper's table repeats it");
  s.obs.add("block2.pos", 3, "block 2 (the right hand's) position (m)");
  s.agents = agents_per_hand(s.obs, s.act);
  s.reward_terms = {
      {"offset", "reward.offset (the paper's 2)"},
      {"left_hand", "-d_left: sum of the left fingertips' distances to block 1 (m)"},
      {"right_hand", "-d_right: sum of the right fingertips' distances to block 2 (m)"},
      {"goal", "goal_scale (goal_offset - d_target), d_target = |b1 - g1| + |b2 - g2| (m)"},
  };
  return s;
}

}  // namespace

const TaskSpec& push_block_spec() {
  static const TaskSpec spec = make_spec();
  return spec;
}

std::unique_ptr<Task> make_push_block(const std::string& config_file) {
  return std::make_unique<PushBlock>(push_block_spec(), load(config_file));
}

}  // namespace bidex::tasks
