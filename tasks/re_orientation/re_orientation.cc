// re_orientation: the spec, the YAML, the scene and the host half of ReOrientation
// (re_orientation.h).
#include <algorithm>
#include <cmath>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/yaml.h"
#include "tasks/re_orientation/re_orientation.h"
#include "tasks/math.h"
#include "tasks/registry.h"

namespace bidex::tasks {

namespace {

ReOrientationParams load(const std::string& file) {
  const YamlView root = YamlView::load_file(file);
  root.allow_keys({"episode_length", "hands", "base", "objects", "reset", "reward", "termination",
                   "curriculum"});
  ReOrientationParams p;
  p.common = manip::load_common(root, file);
  {
    auto b = root.child("objects");
    b.allow_keys({"edge", "density", "friction", "object1", "object2"});
    p.edge = read_number(b, "edge", 0.01, 0.2, "an edge in [0.01, 0.2] m");
    p.density = read_number(b, "density", 1, 20000, "a density in [1, 20000] kg/m^3");
    p.friction = read_number(b, "friction", 0.01, 10, "a sliding friction in [0.01, 10]");
    const char* names[2] = {"object1", "object2"};
    for (int i = 0; i < 2; ++i) {
      auto v = b.child(names[i]);
      v.allow_keys({"start", "goal"});
      p.start[i] = read_vec3(v.child("start"));
      p.goal[i] = read_vec3(v.child("goal"));
    }
  }
  {
    auto r = root.child("reset");
    r.allow_keys({"object_position_noise", "random_object_rotation", "random_goal_rotation",
                  "hand_dof_noise"});
    p.object_position_noise = read_number(r, "object_position_noise", 0, 1, "a noise in [0, 1] m");
    p.random_object_rotation = r.req<bool>("random_object_rotation");
    p.random_goal_rotation = r.req<bool>("random_goal_rotation");
    p.hand_dof_noise = read_number(r, "hand_dof_noise", 0, 1, "a fraction of the joint range in [0, 1]");
  }
  {
    auto r = root.child("reward");
    r.allow_keys({"dist_scale", "rot_scale", "rot_eps", "action_penalty", "goal_bonus",
                  "rotation_tolerance", "goal_mode", "rotation_progress"});
    p.dist_scale = read_number(r, "dist_scale", -1e4, 0, "a scale <= 0");
    p.rot_scale = read_number(r, "rot_scale", 0, 1e4, "a scale >= 0");
    p.rot_eps = read_number(r, "rot_eps", 1e-6, 10, "an epsilon in [1e-6, 10] rad");
    p.action_penalty = read_number(r, "action_penalty", -10, 0, "a coefficient in [-10, 0]");
    p.goal_bonus = read_number(r, "goal_bonus", 0, 1e6, "a bonus >= 0");
    p.rotation_tolerance = read_number(r, "rotation_tolerance", 0, M_PI, "an angle in [0, pi] rad");
    auto mode = r.child("goal_mode");
    const auto m = mode.as<std::string>();
    if (m != "both" && m != "each") mode.fail("'both' or 'each'", mode.repr());
    p.each_goal = m == "each";
    if (r.has("rotation_progress"))  // optional: off (0) when absent
      p.rotation_progress =
          read_number(r, "rotation_progress", 0, 1e4, "a scale in [0, 1e4] per rad");
  }
  if (root.has("curriculum")) {  // optional: off when absent
    auto c = root.child("curriculum");
    c.allow_keys({"enabled", "start", "up", "down"});
    p.curriculum = c.req<bool>("enabled");
    p.curriculum_start = read_number(c, "start", 0, 1, "a level in [0, 1]");
    p.curriculum_up = read_number(c, "up", 0, 1, "a step in [0, 1]");
    p.curriculum_down = read_number(c, "down", 0, 1, "a step in [0, 1]");
  }
  {
    auto t = root.child("termination");
    t.allow_keys({"drop_height"});
    p.drop_height = read_number(t, "drop_height", -10, 10, "a height in [-10, 10] m");
  }
  return p;
}

TaskSpec make_spec() {
  TaskSpec s = manip::spec_with_hands(
      "re_orientation", "Re-Orientation", "ShadowHandReOrientation", HumanAge{18, 18, "18", false},
      Difficulty::kMedium,
      "Refines the ability to move individual fingers and manipulate objects.", 600);
  for (int i = 1; i <= 2; ++i) {
    const std::string o = "object" + std::to_string(i), g = "goal" + std::to_string(i);
    add_object_obs(s.obs, o, "cube " + std::to_string(i));
    add_goal_obs(s.obs, g, "cube " + std::to_string(i) + "'s goal");
  }
  s.hands_collide = false;  // the original's collision filter -1: its hands pass through each other
  s.agents = agents_per_hand(s.obs, s.act);
  s.reward_terms = {
      {"position", "dist_scale (d1 + d2): the cubes' distances to their goal positions (m)"},
      {"rotation1", "rot_scale / (theta1 + rot_eps), theta1 cube 1's rotation distance (rad)"},
      {"rotation2", "rot_scale / (theta2 + rot_eps)"},
      {"goal_bonus", "goal_bonus when both thetas are below rotation_tolerance, then new goals "
                     "(goal_mode both); goal_bonus for each cube whose theta is, then a new "
                     "goal for it (goal_mode each)"},
      {"action_penalty", "action_penalty x sum of squared actions"},
      {"rotation_progress", "rotation_progress x the decrease of theta1 + theta2 since the last "
                            "step (0 at an episode's first step and with rotation_progress 0, "
                            "the default)"},
  };
  return s;
}

}  // namespace

ReOrientation::ReOrientation(const TaskSpec& spec, ReOrientationParams p)
    : BodyTask(spec, p.common), p_(std::move(p)) {
  ReOrientationProgram& g = prog_;
  g.nact = spec.act.dim();
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 3; ++k) {
      g.obj[i].start[k] = p_.start[i][k];
      g.obj[i].goal[k] = p_.goal[i][k];
    }
  g.object_position_noise = p_.object_position_noise;
  g.random_object_rotation = p_.random_object_rotation;
  g.random_goal_rotation = p_.random_goal_rotation;
  g.hand_dof_noise = p_.hand_dof_noise;
  g.dist_scale = p_.dist_scale;
  g.rot_scale = p_.rot_scale;
  g.rot_eps = p_.rot_eps;
  g.action_penalty = p_.action_penalty;
  g.rotation_progress = p_.rotation_progress;
  g.goal_bonus = p_.goal_bonus;
  g.rotation_tolerance = p_.rotation_tolerance;
  g.each_goal = p_.each_goal;
  g.curriculum = p_.curriculum;
  g.curriculum_start = p_.curriculum_start;
  g.curriculum_up = p_.curriculum_up;
  g.curriculum_down = p_.curriculum_down;
  g.drop_height = p_.drop_height;
  g.t_pos = spec.term_index("position");
  g.t_rot[0] = spec.term_index("rotation1");
  g.t_rot[1] = spec.term_index("rotation2");
  g.t_bonus = spec.term_index("goal_bonus");
  g.t_action = spec.term_index("action_penalty");
  g.t_progress = spec.term_index("rotation_progress");
}

sim::SceneBuilder ReOrientation::scene(const sim::HandSpec& right_hand,
                                       const sim::PhysicsOptions& physics) const {
  // the two cubes between the hands take up to 225 constraint rows under MT20's trained policy
  // (bench/results/suites-h200/lease14, summary.json's gpu_rows), past the default GPU room of
  // 192: each world that overflowed was reset mid-episode (501 world-steps in the fifteenth
  // lease's 109M slot-steps); the room keeps 1.4x over the most measured
  sim::SceneBuilder sb = scene_with_hands(right_hand, physics.with_gpu_room(320));
  for (int i = 0; i < 2; ++i) {
    const std::string n = std::to_string(i + 1);
    auto o = manip::cube("object" + n, p_.edge, p_.density, p_.friction, p_.start[i],
                         {1, 0, 0, 0});
    if (i == 1) o.rgba = {0.25, 0.45, 0.85, 1};
    sb.add_object(o);
    sb.add_object(manip::marker_box("goal" + n, p_.edge / 2, p_.goal[i], {1, 0, 0, 0},
                                    {o.rgba[0], o.rgba[1], o.rgba[2], 0.3}));
  }
  return sb;
}

void ReOrientation::bind(const sim::SimModel& model) {
  bind_hands(model, prog_.hands);
  for (int i = 0; i < 2; ++i) {
    const std::string n = std::to_string(i + 1);
    const auto& o = manip::object_index(model, spec().id, "object" + n);
    const auto& g = manip::object_index(model, spec().id, "goal" + n);
    if (o.qpos_adr < 0 || g.mocap < 0)
      throw ModelError("re_orientation: object" + n + " is not free or goal" + n +
                       " not a marker");
    auto& ob = prog_.obj[i];
    ob.body = o.body;
    ob.qpos = o.qpos_adr;
    ob.mocap = g.mocap;
    ob.root_tree = model.mj()->body_rootid[o.body];
  }
}

const TaskSpec& re_orientation_spec() {
  static const TaskSpec spec = make_spec();
  return spec;
}

std::unique_ptr<Task> make_re_orientation(const std::string& config_file) {
  return std::make_unique<ReOrientation>(re_orientation_spec(), load(config_file));
}

}  // namespace bidex::tasks
