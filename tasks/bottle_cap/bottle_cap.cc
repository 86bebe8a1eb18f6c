// bottle_cap: the spec, the YAML, the scene and the host half of BottleCap (bottle_cap.h).
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/yaml.h"
#include "tasks/bottle_cap/bottle_cap.h"
#include "tasks/config_fields.h"
#include "tasks/math.h"
#include "tasks/registry.h"

namespace bidex::tasks {

namespace {

BottleCapParams load(const std::string& file) {
  const YamlView root = YamlView::load_file(file);
  root.allow_keys({"episode_length", "hands", "base", "table", "bottle", "reward", "termination"});
  BottleCapParams p;
  p.common = manip::load_common(root, file);
  p.table = manip::load_table(root.child("table"));
  {
    auto b = root.child("bottle");
    b.allow_keys({"start", "rpy", "density", "friction", "cap_travel", "cap_frictionloss",
                  "cap_damping", "twist_damping", "cap_point"});
    p.bottle_start = read_vec3(b.child("start"));
    p.bottle_rpy = read_vec3(b.child("rpy"));
    p.density = read_number(b, "density", 1, 20000, "a density in [1, 20000] kg/m^3");
    p.friction = read_number(b, "friction", 0.01, 10, "a sliding friction in [0.01, 10]");
    p.cap_travel = read_number(b, "cap_travel", 0.001, 0.5, "a travel in [0.001, 0.5] m");
    p.cap_frictionloss = read_number(b, "cap_frictionloss", 0, 100, "a friction force in [0, 100] N");
    p.cap_damping = read_number(b, "cap_damping", 0, 100, "a damping in [0, 100] N s/m");
    p.twist_damping = read_number(b, "twist_damping", 0, 10, "a damping in [0, 10] N m s/rad");
    p.cap_point = read_number(b, "cap_point", -1, 1, "an offset in [-1, 1] m");
  }
  {
    const auto rv = read_reward_variants(root.child("reward"));
    auto read = [&](const YamlView& r, BottleCapParams& q) {
      std::vector<std::string> keys = {"offset", "open_scale", "goal_gate", "success_opening"};
      keys.insert(keys.end(), rv.extra.begin(), rv.extra.end());
      r.allow_keys(keys);
      q.offset = read_number(r, "offset", -100, 100, "an offset in [-100, 100]");
      q.open_scale = read_number(r, "open_scale", 0, 1e4, "a scale in [0, 1e4]");
      q.goal_gate =
          read_number(r, "goal_gate", 0, 100, "a fingertip distance sum in [0, 100] m (0: off)");
      q.success_opening = read_number(r, "success_opening", 0, 1, "a distance in [0, 1] m");
    };
    read_chosen_variant(rv, p, read);
  }
  {
    auto t = root.child("termination");
    t.allow_keys({"cap_drop_height", "max_right_palm", "max_left_palm"});
    p.cap_drop_height = read_number(t, "cap_drop_height", -10, 10, "a height in [-10, 10] m");
    p.max_right_palm = read_number(t, "max_right_palm", 0, 10, "a distance in [0, 10] m (0: off)");
    p.max_left_palm = read_number(t, "max_left_palm", 0, 10, "a distance in [0, 10] m (0: off)");
  }
  return p;
}

std::string fmt(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::string bottle_body(const BottleCapParams& p) {
  const double rho = p.density, mu = p.friction;
  std::string s;
  // body: a capsule of radius 0.0395 (0.079 m wide) from -0.1375 to 0.0475
  s += manip::geom("bottle_body", "capsule", "0.0395 0.053", {0, 0, -0.045}, rho, mu,
                   "0.3 0.6 0.35 1");
  // neck: radius 0.016, 0.029 to 0.111
  s += manip::geom("bottle_neck", "capsule", "0.016 0.025", {0, 0, 0.07}, rho, mu,
                   "0.3 0.6 0.35 1");
  s += "<body name=\"bottle_cap\" pos=\"0 0 " + fmt(kBottleCapSeat) + "\">\n";
  s += "<joint name=\"bottle_cap_slide\" type=\"slide\" axis=\"0 0 1\" limited=\"true\" range=\"0 " +
       fmt(p.cap_travel) + "\" damping=\"" + fmt(p.cap_damping) + "\" frictionloss=\"" +
       fmt(p.cap_frictionloss) + "\" armature=\"0.001\"/>\n";
  s += "<joint name=\"bottle_cap_twist\" type=\"hinge\" axis=\"0 0 1\" damping=\"" +
       fmt(p.twist_damping) + "\" armature=\"0.0001\"/>\n";
  // cap: a box 0.038 x 0.038 x 0.035 from 0.1025 to 0.1375 when closed
  s += manip::geom("bottle_cap", "box", "0.019 0.019 0.0175", {0, 0, 0}, rho, mu,
                   "0.85 0.3 0.25 1");
  s += "</body>\n";
  return s;
}

TaskSpec make_spec() {
  TaskSpec s = manip::spec_with_hands(
      "bottle_cap", "Open Bottle Cap", "ShadowHandBottleCap", HumanAge{30, 30, "30", false},
      Difficulty::kMedium, "Uses hands to twist things, like turning doorknobs or unscrewing lids.",
      125);
  s.version = 2;  // v2: the original code's reward by default (README, "Reward")
  add_object_obs(s.obs, "bottle", "the bottle");
  s.obs.add("cap.pos", 3, "the cap's centre (m), world frame");
  s.agents = agents_per_hand(s.obs, s.act);
  s.reward_terms = {
      {"offset", "reward.offset per step (the original's 2, the paper's 0.2)"},
      {"right_hand", "-d_right: sum of the right fingertips' distances to the cap point (m)"},
      {"left_hand", "-d_left: distance of the left palm point to the bottle's origin (m)"},
      {"cap_open", "open_scale x the cap's distance from its closed seat (m), while d_right <= "
                   "reward.goal_gate (0: always)"},
  };
  return s;
}

}  // namespace

BottleCap::BottleCap(const TaskSpec& spec, BottleCapParams p)
    : BodyTask(spec, p.common), p_(std::move(p)) {
  BottleCapProgram& g = prog_;
  g.cap_point = p_.cap_point;
  g.offset = p_.offset;
  g.open_scale = p_.open_scale;
  g.goal_gate = p_.goal_gate;
  g.success_opening = p_.success_opening;
  g.cap_drop_height = p_.cap_drop_height;
  g.max_right_palm = p_.max_right_palm;
  g.max_left_palm = p_.max_left_palm;
  g.t_offset = spec.term_index("offset");
  g.t_right = spec.term_index("right_hand");
  g.t_left = spec.term_index("left_hand");
  g.t_open = spec.term_index("cap_open");
}

sim::SceneBuilder BottleCap::scene(const sim::HandSpec& right_hand,
                                   const sim::PhysicsOptions& physics) const {
  sim::SceneBuilder sb = scene_with_hands(right_hand, physics);
  sb.add_object(manip::table("table", p_.table));
  sim::ObjectSpec b;
  b.name = "bottle";
  b.shape = sim::ObjectSpec::Shape::kMjcf;
  b.mjcf_body = bottle_body(p_);
  b.pose.pos = p_.bottle_start;
  b.pose.quat = manip::quat_rpy(p_.bottle_rpy);
  sb.add_object(b);
  return sb;
}

void BottleCap::bind(const sim::SimModel& model) {
  bind_hands(model, prog_.hands);
  prog_.bottle = manip::object_index(model, spec().id, "bottle").body;
  prog_.root_tree = model.mj()->body_rootid[prog_.bottle];
  prog_.cap = mj_name2id(model.mj(), mjOBJ_BODY, "bottle_cap");
  if (prog_.cap < 0) throw ModelError("bottle_cap: the scene lacks the bottle's cap body");
}

const TaskSpec& bottle_cap_spec() {
  static const TaskSpec spec = make_spec();
  return spec;
}

std::unique_ptr<Task> make_bottle_cap(const std::string& config_file) {
  return std::make_unique<BottleCap>(bottle_cap_spec(), load(config_file));
}

}  // namespace bidex::tasks
