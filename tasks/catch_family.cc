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
    : Task(spec, params.file), p_(std::move(params)) {
  nobj_ = static_cast<int>(p_.objects.size());
  if (nobj_ == 1) {
    t_pose_[0] = spec.term_index("pose");
  } else {
    t_pose_[0] = spec.term_index("pose_object1");
    t_pose_[1] = spec.term_index("pose_object2");
  }
  // the start positions are the egg's (4 cm semi-axis): a larger object starts higher by the
  // difference, so that no random orientation puts it inside a hand
  lift_ = std::max(0.0, bounding_radius(p_.object.spec) - 0.04);
  t_bonus_ = spec.term_index("goal_bonus");
  t_fall_ = spec.term_index("fall_penalty");
  t_action_ = spec.term_index("action_penalty");
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
  add_two_hands(sb, right_hand, p_.right, p_.left, base);
  for (int i = 0; i < nobj_; ++i) {
    sim::ObjectSpec o = p_.object.spec;
    o.name = numbered("object", i, nobj_);
    o.pose.pos = p_.objects[i].start;
    sb.add_object(o);
    sim::ObjectSpec g = goal_marker(p_.object, numbered("goal", i, nobj_));
    g.pose.pos = p_.objects[i].goal;
    sb.add_object(g);
  }
  return sb;
}

void CatchTask::bind(const sim::SimModel& model) {
  bind_two_hands(model, p_.force_scale, p_.torque_scale, hands_);
  obj_.clear();
  for (int i = 0; i < nobj_; ++i) {
    const auto* o = model.object(numbered("object", i, nobj_));
    const auto* g = model.object(numbered("goal", i, nobj_));
    if (!o || !g || o->qpos_adr < 0 || g->mocap < 0)
      throw ModelError(spec().id + ": the scene lacks its objects or goal markers");
    obj_.push_back({o->body, o->qpos_adr, g->mocap, model.mj()->body_rootid[o->body]});
  }
}

void CatchTask::reset(TaskSlot& t) const {
  auto& rng = *t.rng;
  mjData* d = t.data;
  // hands: one joint sample for both (as the original), inside the joint ranges
  randomise_hand_joints(hands_, p_.hand_dof_noise, rng, d, t.state.ctrl);
  // objects: one position-noise sample and one orientation for all of them
  double noise[3] = {0, 0, 0};
  if (p_.object_position_noise > 0)
    for (double& x : noise) x = p_.object_position_noise * math::uniform(rng, -1, 1);
  double qo[4] = {1, 0, 0, 0}, qg[4] = {1, 0, 0, 0};
  if (p_.random_object_rotation) math::random_rotation(qo, rng);
  if (p_.random_goal_rotation) math::random_rotation(qg, rng);
  for (int i = 0; i < nobj_; ++i) {
    double* q = d->qpos + obj_[i].qpos;
    for (int k = 0; k < 3; ++k) q[k] = p_.objects[i].start[k] + noise[k];
    q[2] += lift_;
    for (int k = 0; k < 4; ++k) q[3 + k] = qo[k];
    auto& goal = t.task->goal[i];
    for (int k = 0; k < 3; ++k) goal[k] = p_.objects[i].goal[k];
    for (int k = 0; k < 4; ++k) goal[3 + k] = qg[k];
    for (int k = 0; k < 3; ++k) d->mocap_pos[3 * obj_[i].mocap + k] = goal[k];
    for (int k = 0; k < 4; ++k) d->mocap_quat[4 * obj_[i].mocap + k] = goal[3 + k];
  }
}

void CatchTask::apply_actions(const float* a, TaskSlot& t) const {
  apply_two_hand_actions(hands_, a, t.state.ctrl, t.state.base_wrench);
}

void CatchTask::goal_error(const TaskSlot& t, int i, double* d, double* theta) const {
  const double* pos = t.state.xpos + 3 * obj_[i].body;
  const double* quat = t.state.xquat + 4 * obj_[i].body;
  const auto& g = t.task->goal[i];
  *d = math::dist3(pos, g.data());
  *theta = math::rot_distance(quat, g.data() + 3);
}

bool CatchTask::evaluate(TaskSlot& t, double* terms) const {
  const auto& v = t.state;
  double dsum = 0;
  bool fell = false;
  for (int i = 0; i < nobj_; ++i) {
    double d, theta;
    goal_error(t, i, &d, &theta);
    terms[t_pose_[i]] = std::exp(-0.2 * (p_.dist_weight * d + theta));
    dsum += d;
    if (v.xpos[3 * obj_[i].body + 2] <= p_.drop_height) fell = true;
  }
  // success: the object within tolerance (two objects: the sum of distances)
  if (dsum < p_.success_tolerance && !t.task->success) {
    t.task->success = true;
    if (!t.task->bonus_paid) {
      terms[t_bonus_] = p_.goal_bonus;
      t.task->bonus_paid = true;
    }
  }
  double a2 = 0;
  for (int k = 0; k < spec().act.dim(); ++k) a2 += double(t.task->action[k]) * t.task->action[k];
  terms[t_action_] = p_.action_penalty * a2;
  if (fell) terms[t_fall_] = p_.fall_penalty;

  bool drift = false;
  for (int h = 0; h < 2; ++h) {
    if (p_.max_root_drift > 0 &&
        math::dist3(v.xpos + 3 * hands_[h].root_body, p_.root_anchors[h].data()) >= p_.max_root_drift)
      drift = true;
    if (p_.max_palm_drift > 0 &&
        math::dist3(v.xpos + 3 * hands_[h].palm_body, p_.palm_anchors[h].data()) >= p_.max_palm_drift)
      drift = true;
  }
  return fell || drift;
}

void CatchTask::observe(const TaskSlot& t, float* obs) const {
  const auto& v = t.state;
  float* o = observe_two_hands(hands_, v, t.task->action.data(), obs);
  for (int i = 0; i < nobj_; ++i) {
    const int b = obj_[i].body;
    observe_object(v, b, obj_[i].root_tree, o);
    observe_goal(t.task->goal[i].data(), v.xquat + 4 * b, o + 13);
    o += 24;
  }
}

}  // namespace bidex::tasks
