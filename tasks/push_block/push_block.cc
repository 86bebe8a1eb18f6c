// push_block: the spec, the YAML, the scene and the host half of PushBlock (push_block.h).
#include <cmath>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/yaml.h"
#include "tasks/push_block/push_block.h"
#include "tasks/math.h"
#include "tasks/registry.h"

namespace bidex::tasks {

namespace {

PushBlockParams load(const std::string& file) {
  const YamlView root = YamlView::load_file(file);
  root.allow_keys({"episode_length", "hands", "base", "table", "blocks", "reward", "termination"});
  PushBlockParams p;
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

TaskSpec make_spec() {
  TaskSpec s = manip::spec_with_hands(
      "push_block", "Push Block", "ShadowHandPushBlock", HumanAge{5, 6, "5-6", false},
      Difficulty::kEasy,
      "Extends one or both arms forward and touches the block with either hand.", 125);
  add_object_obs(s.obs, "block1", "block 1 (the left hand's)");
  s.obs.add("block1.pos", 3, "block 1 position (m), as the paper's table repeats it");
  s.obs.add("block2.pos", 3, "block 2 (the right hand's) position (m)");
  s.hands_collide = false;  // the original's collision filter -1: its hands pass through each other
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

PushBlock::PushBlock(const TaskSpec& spec, PushBlockParams p)
    : BodyTask(spec, p.common), p_(std::move(p)) {
  PushBlockProgram& g = prog_;
  const sim::Quat q = manip::quat_rpy(p_.blocks.rpy);
  for (int i = 0; i < 2; ++i) {
    for (int k = 0; k < 3; ++k) g.goal[i][k] = p_.blocks.place[i][k];
    for (int k = 0; k < 4; ++k) g.goal[i][3 + k] = q[k];
  }
  g.offset = p_.offset;
  g.goal_scale = p_.goal_scale;
  g.goal_offset = p_.goal_offset;
  g.success_tolerance = p_.success_tolerance;
  g.max_tip_distance = p_.max_tip_distance;
  g.t_offset = spec.term_index("offset");
  g.t_left = spec.term_index("left_hand");
  g.t_right = spec.term_index("right_hand");
  g.t_goal = spec.term_index("goal");
}

sim::SceneBuilder PushBlock::scene(const sim::HandSpec& right_hand,
                                   const sim::PhysicsOptions& physics) const {
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

void PushBlock::bind(const sim::SimModel& model) {
  bind_hands(model, prog_.hands);
  for (int i = 0; i < 2; ++i) {
    const auto& o = manip::object_index(model, spec().id, "block" + std::to_string(i + 1));
    prog_.body[i] = o.body;
    prog_.root_tree[i] = model.mj()->body_rootid[o.body];
  }
}

const TaskSpec& push_block_spec() {
  static const TaskSpec spec = make_spec();
  return spec;
}

std::unique_ptr<Task> make_push_block(const std::string& config_file) {
  return std::make_unique<PushBlock>(push_block_spec(), load(config_file));
}

}  // namespace bidex::tasks
