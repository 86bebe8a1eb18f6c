#include "tasks/catch_family.h"

#include <algorithm>
#include <cmath>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/yaml.h"
#include "tasks/config_fields.h"
#include "tasks/math.h"

namespace bidex::tasks {

// ---- spec ---------------------------------------------------------------------------------

TaskSpec catch_family_spec(std::string id, std::string paper_name, std::string original_name,
                           HumanAge age, Difficulty difficulty, std::string skill,
                           int episode_length, bool free_base, int nobjects) {
  TaskSpec s = two_hand_spec(std::move(id), std::move(paper_name), std::move(original_name),
                             std::move(age), difficulty, std::move(skill), episode_length,
                             free_base);
  for (int i = 0; i < nobjects; ++i) {
    const std::string n = nobjects == 1 ? "" : std::to_string(i + 1);
    const std::string o = "object" + n, g = "goal" + n;
    add_object_obs(s.obs, o, "the " + o);
    add_goal_obs(s.obs, g, "the " + o + "'s goal");
  }
  s.agents = agents_per_hand(s.obs, s.act);
  s.goal_shifts = nobjects;
  s.hands_collide = false;  // the original's filter -1 in every catch task and ML1
  if (nobjects == 1) {
    s.reward_terms.push_back({"pose", "exp(-0.2 (alpha d + theta)): d the object's distance to "
                                      "the goal (m), theta the rotation between them (rad)"});
  } else {
    for (int i = 1; i <= 2; ++i)
      s.reward_terms.push_back({"pose_object" + std::to_string(i),
                                "exp(-0.2 (alpha d_i + theta_i)) of object " + std::to_string(i)});
  }
  s.reward_terms.push_back({"goal_bonus", "reward.goal_bonus, once, on the first step of success"});
  s.reward_terms.push_back({"fall_penalty", "reward.fall_penalty on the step an object falls"});
  s.reward_terms.push_back({"action_penalty", "reward.action_penalty x sum of squared actions"});
  return s;
}

// ---- config -------------------------------------------------------------------------------

namespace {

std::vector<sim::Vec3> anchors(const YamlView& v) {
  auto items = v.items();
  if (items.size() != 2) v.fail("2 positions (right hand, left hand)", v.repr());
  return {read_vec3(items[0]), read_vec3(items[1])};
}

}  // namespace

CatchParams load_catch_params(const std::string& file, const TaskSpec& spec) {
  const YamlView root = YamlView::load_file(file);
  root.allow_keys({"episode_length", "object", "hands", "objects", "reset", "base", "reward",
                   "termination"});
  CatchParams p;
  p.file = file;
  p.episode_length = read_episode_length(root);
  p.object = parse_object(root.child("object"));
  read_hand_poses(root, &p.right, &p.left);
  {
    auto v = root.child("objects");
    const int want = spec.obs.find("object.pose") ? 1 : 2;
    auto items = v.items();
    if (static_cast<int>(items.size()) != want)
      v.fail(std::to_string(want) + " object(s) for " + spec.id,
             std::to_string(items.size()) + " entries");
    for (auto& it : items) {
      it.allow_keys({"start", "goal"});
      p.objects.push_back({read_vec3(it.child("start")), read_vec3(it.child("goal"))});
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
  if (spec.free_base) {
    read_base_scales(root, &p.force_scale, &p.torque_scale);
  } else if (root.has("base")) {
    root.child("base").fail("no 'base' section: " + spec.id + " has fixed bases", "a base section");
  }
  {
    auto r = root.child("reward");
    r.allow_keys({"dist_weight", "success_tolerance", "action_penalty", "goal_bonus",
                  "fall_penalty"});
    p.dist_weight = read_number(r, "dist_weight", 0, 1e4, "a weight >= 0");
    p.success_tolerance = read_number(r, "success_tolerance", 0, 10, "a distance in [0, 10] m");
    p.action_penalty = read_number(r, "action_penalty", -10, 0, "a coefficient in [-10, 0]");
    p.goal_bonus = read_number(r, "goal_bonus", 0, 1e6, "a bonus >= 0");
    p.fall_penalty = read_number(r, "fall_penalty", -1e6, 0, "a penalty <= 0");
  }
  {
    auto t = root.child("termination");
    t.allow_keys({"drop_height", "max_root_drift", "root_anchors", "max_palm_drift",
                  "palm_anchors"});
    p.drop_height = read_number(t, "drop_height", -10, 10, "a height in [-10, 10] m");
    p.max_root_drift = read_number(t, "max_root_drift", 0, 10, "a distance in [0, 10] m (0: off)");
    p.max_palm_drift = read_number(t, "max_palm_drift", 0, 10, "a distance in [0, 10] m (0: off)");
    p.root_anchors = {p.right.pos, p.left.pos};
    if (auto a = t.maybe("root_anchors")) p.root_anchors = anchors(*a);
    if (auto a = t.maybe("palm_anchors")) {
      p.palm_anchors = anchors(*a);
    } else if (p.max_palm_drift > 0) {
      t.child("palm_anchors");  // required with max_palm_drift: throws naming the key
    }
    if (!spec.free_base && (p.max_root_drift > 0 || p.max_palm_drift > 0))
      t.fail("no drift limits: " + spec.id + " has fixed bases", "max_*_drift > 0");
  }
  return p;
}

std::unique_ptr<Task> make_catch_task(const TaskSpec& spec, const std::string& config_file) {
  return std::make_unique<CatchTask>(spec, load_catch_params(config_file, spec));
}

// ---- task ---------------------------------------------------------------------------------

CatchTask::CatchTask(const TaskSpec& spec, CatchParams params)
    : BodyTask(spec, params.file), p_(std::move(params)) {
  CatchProgram& g = prog_;
  g.nact = spec.act.dim();
  g.nobj = static_cast<int>(p_.objects.size());
  if (g.nobj == 1) {
    g.t_pose[0] = spec.term_index("pose");
  } else {
    g.t_pose[0] = spec.term_index("pose_object1");
    g.t_pose[1] = spec.term_index("pose_object2");
  }
  g.t_bonus = spec.term_index("goal_bonus");
  g.t_fall = spec.term_index("fall_penalty");
  g.t_action = spec.term_index("action_penalty");
  // the start positions are the egg's (4 cm semi-axis): a larger object starts higher by the
  // difference, so that no random orientation puts it inside a hand
  g.lift = std::max(0.0, bounding_radius(p_.object.spec) - 0.04);
  for (int i = 0; i < g.nobj; ++i)
    for (int k = 0; k < 3; ++k) {
      g.obj[i].start[k] = p_.objects[i].start[k];
      g.obj[i].goal[k] = p_.objects[i].goal[k];
    }
  g.object_position_noise = p_.object_position_noise;
  g.random_object_rotation = p_.random_object_rotation;
  g.random_goal_rotation = p_.random_goal_rotation;
  g.hand_dof_noise = p_.hand_dof_noise;
  g.dist_weight = p_.dist_weight;
  g.success_tolerance = p_.success_tolerance;
  g.action_penalty = p_.action_penalty;
  g.goal_bonus = p_.goal_bonus;
  g.fall_penalty = p_.fall_penalty;
  g.drop_height = p_.drop_height;
  g.max_root_drift = p_.max_root_drift;
  g.max_palm_drift = p_.max_palm_drift;
  for (int h = 0; h < 2; ++h)
    for (int k = 0; k < 3; ++k) {
      if (!p_.root_anchors.empty()) g.root_anchor[h][k] = p_.root_anchors[h][k];
      if (!p_.palm_anchors.empty()) g.palm_anchor[h][k] = p_.palm_anchors[h][k];
    }
}

namespace {
std::string numbered(const char* base, int i, int n) {
  return n == 1 ? std::string(base) : std::string(base) + std::to_string(i + 1);
}
}  // namespace

sim::SceneBuilder CatchTask::scene(const sim::HandSpec& right_hand,
                                   const sim::PhysicsOptions& physics) const {
  sim::SceneBuilder sb(physics);
  const auto base = spec().free_base ? sim::Base::kFree : sim::Base::kFixed;
  add_two_hands(sb, right_hand, p_.right, p_.left, base, spec().hands_collide);
  const int nobj = prog_.nobj;
  for (int i = 0; i < nobj; ++i) {
    sim::ObjectSpec o = p_.object.spec;
    o.name = numbered("object", i, nobj);
    o.pose.pos = p_.objects[i].start;
    sb.add_object(o);
    sim::ObjectSpec g = goal_marker(p_.object, numbered("goal", i, nobj));
    g.pose.pos = p_.objects[i].goal;
    sb.add_object(g);
  }
  return sb;
}

void CatchTask::bind(const sim::SimModel& model) {
  bind_two_hands(model, p_.force_scale, p_.torque_scale, prog_.hands);
  const int nobj = prog_.nobj;
  for (int i = 0; i < nobj; ++i) {
    const auto* o = model.object(numbered("object", i, nobj));
    const auto* g = model.object(numbered("goal", i, nobj));
    if (!o || !g || o->qpos_adr < 0 || g->mocap < 0)
      throw ModelError(spec().id + ": the scene lacks its objects or goal markers");
    auto& ob = prog_.obj[i];
    ob.body = o->body;
    ob.qpos = o->qpos_adr;
    ob.mocap = g->mocap;
    ob.root_tree = model.mj()->body_rootid[o->body];
  }
}

void CatchTask::goal_error(const TaskSlot& t, int i, double* d, double* theta) const {
  catch_goal_error(prog_, world_rows(t), *t.task, i, d, theta);
}

}  // namespace bidex::tasks
