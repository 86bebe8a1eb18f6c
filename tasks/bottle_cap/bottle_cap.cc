// bottle_cap: Open Bottle Cap (the original's ShadowHandBottleCap); defaults in bottle_cap.yaml,
// decisions in README.md. One hand holds the bottle, the other pulls its cap off along the
// bottle's axis (a slide joint with a limit, friction and damping, and a free twist).
#include <cmath>
#include <cstdio>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/yaml.h"
#include "tasks/manipulation_family.h"
#include "tasks/math.h"
#include "tasks/registry.h"

namespace bidex::tasks {

namespace {

struct CapParams {
  manip::CommonParams common;
  manip::TableParams table;
  sim::Vec3 bottle_start{}, bottle_rpy{};
  double density = 500, friction = 1;
  double cap_travel = 0.064;      // slide range [0, travel] (m)
  double cap_frictionloss = 0.5;  // N: the pull the cap needs before it moves
  double cap_damping = 1;         // N s/m
  double twist_damping = 0.001;   // N m s/rad
  double cap_point = 0.15;        // c = bottle origin + R (0, 0, cap_point)
  // reward: offset - d_right - d_left + open_scale d_open
  double offset = 0.2, open_scale = 30;
  double goal_gate = 0;           // > 0: the opening term only while d_right <= it
  double success_opening = 0.03;  // m
  // termination
  double cap_drop_height = 0.5;   // z(c) at or below
  double max_right_palm = 0.5;    // |c - palm_R| at or above
  double max_left_palm = 0.2;     // |b - palm_L| at or above
};

CapParams load(const std::string& file) {
  const YamlView root = YamlView::load_file(file);
  root.allow_keys({"episode_length", "hands", "base", "table", "bottle", "reward", "termination"});
  CapParams p;
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
    auto r = root.child("reward");
    r.allow_keys({"offset", "open_scale", "goal_gate", "success_opening"});
    p.offset = read_number(r, "offset", -100, 100, "an offset in [-100, 100]");
    p.open_scale = read_number(r, "open_scale", 0, 1e4, "a scale in [0, 1e4]");
    p.goal_gate = read_number(r, "goal_gate", 0, 100, "a fingertip distance sum in [0, 100] m (0: off)");
    p.success_opening = read_number(r, "success_opening", 0, 1, "a distance in [0, 1] m");
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

// Bottle frame: axis +z, origin at the bottle's centre, 0.275 m tall (-0.1375 to 0.1375).
constexpr double kCapSeat = 0.12;  // cap body origin (the cap's centre) when closed

std::string fmt(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::string bottle_body(const CapParams& p) {
  const double rho = p.density, mu = p.friction;
  std::string s;
  // body: a capsule of radius 0.0395 (0.079 m wide) from -0.1375 to 0.0475
  s += manip::geom("bottle_body", "capsule", "0.0395 0.053", {0, 0, -0.045}, rho, mu,
                   "0.3 0.6 0.35 1");
  // neck: radius 0.016, 0.029 to 0.111
  s += manip::geom("bottle_neck", "capsule", "0.016 0.025", {0, 0, 0.07}, rho, mu,
                   "0.3 0.6 0.35 1");
  s += "<body name=\"bottle_cap\" pos=\"0 0 " + fmt(kCapSeat) + "\">\n";
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

class BottleCap : public manip::ManipTask {
 public:
  BottleCap(const TaskSpec& spec, CapParams p) : ManipTask(spec, p.common), p_(std::move(p)) {}

  sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                          const sim::PhysicsOptions& physics) const override {
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

  void bind(const sim::SimModel& model) override {
    bind_hands(model);
    bottle_ = manip::object_index(model, spec().id, "bottle").body;
    tree_ = model.mj()->body_rootid[bottle_];
    cap_ = mj_name2id(model.mj(), mjOBJ_BODY, "bottle_cap");
    if (cap_ < 0) throw ModelError("bottle_cap: the scene lacks the bottle's cap body");
    t_offset_ = spec().term_index("offset");
    t_right_ = spec().term_index("right_hand");
    t_left_ = spec().term_index("left_hand");
    t_open_ = spec().term_index("cap_open");
  }

  void reset(TaskSlot&) const override {}  // bottle at its start pose, cap closed (the sim's reset)

  // The cap's distance from its closed seat (m): the paper's |x_bottle - x_cap| measured from
  // where the cap sits when closed.
  double opening(const sim::SlotView& v) const {
    const double seat_local[3] = {0, 0, kCapSeat};
    double seat[3];
    manip::body_point(v, bottle_, seat_local, seat);
    return math::dist3(v.xpos + 3 * cap_, seat);
  }

  bool evaluate(TaskSlot& t, double* terms) const override {
    const auto& v = t.state;
    const double* b = v.xpos + 3 * bottle_;
    const double cap_local[3] = {0, 0, p_.cap_point};
    double c[3], palm_r[3], palm_l[3];
    manip::body_point(v, bottle_, cap_local, c);
    palm_point(hands_[0], v, palm_r);
    palm_point(hands_[1], v, palm_l);
    const double d_right = tip_distance_sum(hands_[0], v, c);
    const double d_left = math::dist3(b, palm_l);
    const double d_open = opening(v);
    terms[t_offset_] = p_.offset;
    terms[t_right_] = -d_right;
    terms[t_left_] = -d_left;
    const bool gate_open = p_.goal_gate <= 0 || d_right <= p_.goal_gate;
    terms[t_open_] = gate_open ? p_.open_scale * d_open : 0.0;
    if (d_open > p_.success_opening) t.task->success = true;
    bool end = c[2] <= p_.cap_drop_height;
    if (p_.max_right_palm > 0 && math::dist3(c, palm_r) >= p_.max_right_palm) end = true;
    if (p_.max_left_palm > 0 && d_left >= p_.max_left_palm) end = true;
    return end;
  }

  void observe(const TaskSlot& t, float* obs) const override {
    float* o = observe_hands(t, obs);
    observe_object(t.state, bottle_, tree_, o);
    manip::put3(o + 13, t.state.xpos + 3 * cap_);
  }

 private:
  CapParams p_;
  int bottle_ = -1, tree_ = -1, cap_ = -1;
  int t_offset_ = -1, t_right_ = -1, t_left_ = -1, t_open_ = -1;
};

TaskSpec make_spec() {
  TaskSpec s = manip::spec_with_hands(
      "bottle_cap", "Open Bottle Cap", "ShadowHandBottleCap", HumanAge{30, 30, "30", false},
      Difficulty::kMedium, "Uses hands to twist things, like turning doorknobs or unscrewing lids.",
      125);
  add_object_obs(s.obs, "bottle", "the bottle");
  s.obs.add("cap.pos", 3, "the cap's centre (m), world frame");
  s.agents = agents_per_hand(s.obs, s.act);
  s.reward_terms = {
      {"offset", "reward.offset (the paper's 0.2)"},
      {"right_hand", "-d_right: sum of the right fingertips' distances to the cap point (m)"},
      {"left_hand", "-d_left: distance of the left palm point to the bottle's origin (m)"},
      {"cap_open", "open_scale x the cap's distance from its closed seat (m)"},
  };
  return s;
}

}  // namespace

const TaskSpec& bottle_cap_spec() {
  static const TaskSpec spec = make_spec();
  return spec;
}

std::unique_ptr<Task> make_bottle_cap(const std::string& config_file) {
  return std::make_unique<BottleCap>(bottle_cap_spec(), load(config_file));
}

}  // namespace bidex::tasks
