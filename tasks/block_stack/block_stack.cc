// block_stack: the spec, the YAML, the scene and the host half of BlockStack (block_stack.h).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/yaml.h"
#include "tasks/block_stack/block_stack.h"
#include "tasks/config_fields.h"
#include "tasks/math.h"
#include "tasks/registry.h"

namespace bidex::tasks {

namespace {

BlockStackParams load(const std::string& file) {
  const YamlView root = YamlView::load_file(file);
  root.allow_keys({"episode_length", "hands", "base", "table", "blocks", "reward", "termination"});
  BlockStackParams p;
  p.common = manip::load_common(root, file);
  p.table = manip::load_table(root.child("table"));
  p.blocks = manip::load_block_pair(root.child("blocks"), "target");
  {
    const auto rv = read_reward_variants(root.child("reward"));
    auto read = [&](const YamlView& r, BlockStackParams& q) {
      std::vector<std::string> keys = {"offset",          "goal_scale",       "goal_offset",
                                       "goal_gate",       "stack_bonus_scale", "stack_tolerance",
                                       "height_tolerance"};
      keys.insert(keys.end(), rv.extra.begin(), rv.extra.end());
      r.allow_keys(keys);
      q.offset = read_number(r, "offset", -100, 100, "an offset in [-100, 100]");
      q.goal_scale = read_number(r, "goal_scale", 0, 1000, "a scale in [0, 1000]");
      q.goal_offset = read_number(r, "goal_offset", -10, 10, "a distance in [-10, 10] m");
      q.goal_gate =
          read_number(r, "goal_gate", 0, 100, "a fingertip distance sum in [0, 100] m (0: off)");
      q.stack_bonus_scale = read_number(r, "stack_bonus_scale", 0, 1e4, "a scale in [0, 1e4]");
      q.stack_tolerance = read_number(r, "stack_tolerance", 0, 1, "a distance in [0, 1] m");
      q.height_tolerance = read_number(r, "height_tolerance", 0, 1, "a distance in [0, 1] m");
    };
    read_chosen_variant(rv, p, read);
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
      "block_stack", "Stack Block", "ShadowHandBlockStack", HumanAge{22, 28, "22-28", false},
      Difficulty::kMedium, "Stacks at least 2 blocks in any trial.", 250);
  s.version = 2;  // v2: the original code's reward by default (README, "Reward")
  add_object_obs(s.obs, "block1", "block 1 (the left hand's, the top one)");
  add_goal_obs(s.obs, "goal", "block 1's target, on top of block 2's target");
  s.obs.add("block1.pos", 3, "block 1 position (m), as the paper's table repeats it");
  s.obs.add("block2.pos", 3, "block 2 (the right hand's, the bottom one) position (m)");
  s.agents = agents_per_hand(s.obs, s.act);
  s.reward_terms = {
      {"offset", "reward.offset (the paper's 1.5)"},
      {"left_hand", "-d_left: sum of the left fingertips' distances to block 1 (m)"},
      {"right_hand", "-d_right: sum of the right fingertips' distances to block 2 (m)"},
      {"goal", "goal_scale (goal_offset - d_target), d_target = |b1 - t1| + |b2 - t2| (m), "
               "while both hands' sums are below reward.goal_gate (0: always)"},
      {"stack_bonus", "stack_bonus_scale (0.05 - |z(t1) - z(b1)|) while both blocks are within "
                      "stack_tolerance of their targets (the original's 50; 0 in the paper's "
                      "formula)"},
  };
  return s;
}

}  // namespace

BlockStack::BlockStack(const TaskSpec& spec, BlockStackParams p)
    : BodyTask(spec, p.common), p_(std::move(p)) {
  BlockStackProgram& g = prog_;
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 3; ++k) g.target[i][k] = p_.blocks.place[i][k];
  const sim::Quat q = manip::quat_rpy(p_.blocks.rpy);
  for (int k = 0; k < 3; ++k) g.goal[k] = p_.blocks.place[0][k];
  for (int k = 0; k < 4; ++k) g.goal[3 + k] = q[k];
  g.offset = p_.offset;
  g.goal_scale = p_.goal_scale;
  g.goal_offset = p_.goal_offset;
  g.goal_gate = p_.goal_gate;
  g.stack_bonus_scale = p_.stack_bonus_scale;
  g.stack_tolerance = p_.stack_tolerance;
  g.height_tolerance = p_.height_tolerance;
  g.max_tip_distance = p_.max_tip_distance;
  g.t_offset = spec.term_index("offset");
  g.t_left = spec.term_index("left_hand");
  g.t_right = spec.term_index("right_hand");
  g.t_goal = spec.term_index("goal");
  g.t_stack = spec.term_index("stack_bonus");
}

sim::SceneBuilder BlockStack::scene(const sim::HandSpec& right_hand,
                                    const sim::PhysicsOptions& physics) const {
  // two blocks on the table take up to 202 constraint rows in PPO's runs (bench/results/
  // sweep-h100x4/lease2, summary.json's gpu_rows), past the default GPU room of 192 (an
  // overflowing world is reset); the room keeps 1.25x over the most measured
  sim::SceneBuilder sb = scene_with_hands(right_hand, physics.with_gpu_room(256));
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

void BlockStack::bind(const sim::SimModel& model) {
  bind_hands(model, prog_.hands);
  for (int i = 0; i < 2; ++i) {
    const auto& o = manip::object_index(model, spec().id, "block" + std::to_string(i + 1));
    prog_.body[i] = o.body;
    prog_.root_tree[i] = model.mj()->body_rootid[o.body];
  }
}

const TaskSpec& block_stack_spec() {
  static const TaskSpec spec = make_spec();
  return spec;
}

std::unique_ptr<Task> make_block_stack(const std::string& config_file) {
  return std::make_unique<BlockStack>(block_stack_spec(), load(config_file));
}

}  // namespace bidex::tasks
