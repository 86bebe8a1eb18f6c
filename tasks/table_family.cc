#include "tasks/table_family.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/yaml.h"
#include "tasks/config_fields.h"
#include "tasks/math.h"
#include "tasks/objects.h"

namespace bidex::tasks {

namespace g = table_geom;

namespace {

bool has_joint(TableKind k) {
  return k == TableKind::kScissors || k == TableKind::kPen || k == TableKind::kSwitch;
}
bool has_second(TableKind k) { return k == TableKind::kSwitch || k == TableKind::kPourWater; }

// ---- the kinds' parameter tables: YAML key -> field, allowed range --------------------------

struct Num {
  const char* key;
  double TableParams::*field;
  double lo, hi;
  const char* what;
};

std::vector<Num> reward_keys(TableKind k) {
  using P = TableParams;
  switch (k) {
    case TableKind::kSwingCup:
      return {{"gate", &P::gate, 0, 100, "a distance sum in [0, 100] m"},
              {"rot_scale", &P::goal_scale, 0, 1e3, "a scale in [0, 1000]"},
              {"rot_eps", &P::rot_eps, 1e-6, 10, "an epsilon in [1e-6, 10] rad"},
              {"rot_offset", &P::goal_offset, -1e3, 1e3, "an offset in [-1000, 1000]"},
              {"goal_yaw", &P::goal_yaw, -10, 10, "an angle in [-10, 10] rad"},
              {"success_angle", &P::success, 0, M_PI, "an angle in [0, pi] rad"}};
    case TableKind::kScissors:
      return {{"offset", &P::offset, -1e3, 1e3, "an offset in [-1000, 1000]"},
              {"gate", &P::gate, 0, 100, "a distance sum in [0, 100] m"},
              {"angle_scale", &P::goal_scale, 0, 1e3, "a scale in [0, 1000]"},
              {"angle_offset", &P::goal_offset, -10, 10, "an offset in [-10, 10] rad"},
              {"target_angle", &P::target_angle, g::kScissorsLower, g::kScissorsUpper,
               "an angle inside the joint range [-0.5969, 0.4] rad"},
              {"success_angle", &P::success, g::kScissorsLower, g::kScissorsUpper,
               "an angle inside the joint range [-0.5969, 0.4] rad"}};
    case TableKind::kPen:
      return {{"gate", &P::gate, 0, 100, "a distance sum in [0, 100] m"},
              {"reach_scale", &P::reach_scale, 0, 1e3, "a scale in [0, 1000] 1/m"},
              {"separation_scale", &P::goal_scale, 0, 1e3, "a scale in [0, 1000] 1/m"},
              {"separation_offset", &P::goal_offset, -1e3, 1e3, "an offset in [-1000, 1000]"},
              {"success_separation", &P::success, 0.19, 0.18 + g::kPenTravel,
               "a separation in [0.19, 0.672] m (the start is 0.18, the slide's end 0.672)"}};
    case TableKind::kSwitch:
      return {{"offset", &P::offset, -1e3, 1e3, "an offset in [-1000, 1000]"},
              {"press_scale", &P::goal_scale, 0, 1e3, "a scale in [0, 1000] 1/m"},
              {"press_offset", &P::goal_offset, -1e3, 1e3, "an offset in [-1000, 1000] m"},
              {"success_distance", &P::success, 0, 0.045,
               "a distance in [0, 0.045] m (0.04497 with both switches off)"}};
    case TableKind::kPourWater:
      return {{"offset", &P::offset, -1e3, 1e3, "an offset in [-1000, 1000]"},
              {"gate", &P::gate, 0, 100, "a distance sum in [0, 100] m"},
              {"pour_scale", &P::goal_scale, 0, 1e3, "a scale in [0, 1000] 1/m"},
              {"pour_offset", &P::goal_offset, -1e3, 1e3, "an offset in [-1000, 1000] m"},
              {"lift_scale", &P::lift_scale, 0, 1e3, "a scale in [0, 1000] 1/m"},
              {"lift_max", &P::lift_max, 0, 1, "a height in [0, 1] m"},
              {"success_distance", &P::success, 0, 1, "a distance in [0, 1] m"}};
  }
  return {};
}

std::vector<Num> termination_keys(TableKind k) {
  using P = TableParams;
  switch (k) {
    case TableKind::kSwingCup:
    case TableKind::kPourWater:
      return {{"drop_height", &P::drop_height, -10, 10, "a height in [-10, 10] m"}};
    case TableKind::kScissors:
    case TableKind::kPen:
      return {{"max_reach", &P::max_reach, 0, 100, "a distance sum in (0, 100] m"}};
    case TableKind::kSwitch:
      return {};
  }
  return {};
}

void read_numbers(const YamlView& v, const std::vector<Num>& keys, TableParams& p,
                  const std::vector<std::string>& extra = {}) {
  std::vector<std::string> names = extra;
  for (auto& n : keys) names.push_back(n.key);
  v.allow_keys(names);
  for (auto& n : keys) p.*n.field = read_number(v, n.key, n.lo, n.hi, n.what);
}

TableParams::Pose pose(const YamlView& v, std::vector<std::string> more = {}) {
  more.push_back("pos");
  more.push_back("rpy");
  v.allow_keys(more);
  return {read_vec3(v.child("pos")), read_vec3(v.child("rpy"))};
}

}  // namespace

// ---- config -------------------------------------------------------------------------------

TableParams load_table_params(const std::string& file, TableKind kind) {
  const YamlView root = YamlView::load_file(file);
  const char* second = kind == TableKind::kSwitch ? "switch2" : "bucket";
  std::vector<std::string> top = {"episode_length", "hands", "object", "table", "reset", "base",
                                  "reward"};
  if (has_second(kind)) top.push_back(second);
  if (kind == TableKind::kPourWater) top.push_back("water");
  if (kind != TableKind::kSwitch) top.push_back("termination");
  root.allow_keys(top);
  TableParams p;
  p.file = file;
  p.episode_length = read_episode_length(root);
  read_hand_poses(root, &p.right, &p.left);
  {
    auto o = root.child("object");
    std::vector<std::string> extra = {"friction", "density"};
    if (has_joint(kind)) extra.push_back("joint_damping");
    p.object = pose(o, extra);
    p.object_friction = read_number(o, "friction", 0, 10, "a friction coefficient in [0, 10]");
    p.density = read_number(o, "density", 1, 1e5, "a density in [1, 1e5] kg/m^3");
    if (has_joint(kind))
      p.joint_damping = read_number(o, "joint_damping", 0, 100, "a damping in [0, 100]");
  }
  if (has_second(kind)) p.second = pose(root.child(second));
  if (kind == TableKind::kPourWater) {
    auto w = root.child("water");
    w.allow_keys({"count", "radius"});
    auto c = w.child("count");
    p.water_count = c.as<int>();
    if (p.water_count < 0 || p.water_count > 30) c.fail("a count in [0, 30]", c.repr());
    p.water_radius = read_number(w, "radius", 0.003, 0.012, "a radius in [0.003, 0.012] m");
  }
  {
    auto t = root.child("table");
    t.allow_keys({"pos", "size"});
    p.table_pos = read_vec3(t.child("pos"));
    auto sv = t.child("size");
    p.table_size = read_vec3(sv);
    for (double x : p.table_size)
      if (!(x > 0)) sv.fail("sizes > 0 (m)", sv.repr());
  }
  {
    auto r = root.child("reset");
    if (kind == TableKind::kScissors) {
      r.allow_keys({"hand_dof_noise", "joint_angle"});
      p.reset_angle = read_number(r, "joint_angle", g::kScissorsLower, g::kScissorsUpper,
                             "an angle inside the joint range [-0.5969, 0.4] rad");
    } else {
      r.allow_keys({"hand_dof_noise"});
    }
    p.hand_dof_noise = read_number(r, "hand_dof_noise", 0, 1, "a fraction of the joint range in [0, 1]");
  }
  read_base_scales(root, &p.force_scale, &p.torque_scale);
  {
    // pour_water's own values are bidex's reward (a lift term, a steeper pour term; its
    // README, "Reward"), its `paper` map the printed formula with the original's gate
    const auto rv = read_reward_variants(root.child("reward"),
                                         kind == TableKind::kPourWater ? "bidex" : "");
    read_chosen_variant(rv, p, [&](const YamlView& r, TableParams& q) {
      read_numbers(r, reward_keys(kind), q, rv.extra);
    });
  }
  if (kind != TableKind::kSwitch) {
    auto t = root.child("termination");
    read_numbers(t, termination_keys(kind), p);
    if (p.max_reach == 0 && (kind == TableKind::kScissors || kind == TableKind::kPen))
      t.child("max_reach").fail("a distance sum in (0, 100] m", "0");
  }
  return p;
}

// ---- spec ---------------------------------------------------------------------------------

TaskSpec table_family_spec(TableKind kind, std::string id, std::string paper_name,
                           std::string original_name, HumanAge age, std::string skill,
                           int episode_length, int version) {
  TaskSpec s = two_hand_spec(std::move(id), std::move(paper_name), std::move(original_name),
                             std::move(age), kind == TableKind::kPourWater ? Difficulty::kHard : Difficulty::kEasy, std::move(skill), episode_length,
                             true);
  // the original's Kettle (pour_water) creates its hands with filter -1, its other table tasks
  // with 0
  s.hands_collide = kind != TableKind::kPourWater;
  s.version = version;
  const char* what = "";
  const char* goal = "";
  const char* rot = "";
  const char* p1 = "";
  const char* p2 = "";
  const char* n1 = "";
  const char* n2 = "";
  switch (kind) {
    case TableKind::kSwingCup:
      what = "the cup";
      goal = "the cup's goal pose: its start position, turned to yaw reward.goal_yaw about z";
      rot = "cup orientation times the goal's conjugate, (x, y, z, w)";
      n1 = "handle.right", p1 = "the cup's right handle (centre), world frame (m)";
      n2 = "handle.left", p2 = "the cup's left handle (centre), world frame (m)";
      break;
    case TableKind::kScissors:
      what = "the scissors (the half with the left handle: the root)";
      goal = "the pose the moving half (right handle) has at reward.target_angle, given the "
             "root's current pose";
      rot = "moving half's orientation times the goal's conjugate, (x, y, z, w)";
      n1 = "handle.right", p1 = "the scissors' right handle (moving half), world frame (m)";
      n2 = "handle.left", p2 = "the scissors' left handle (root half), world frame (m)";
      break;
    case TableKind::kPen:
      what = "the pen body (the root)";
      goal = "the pose the cap has when the grip points are reward.success_separation apart, "
             "given the body's current pose";
      rot = "cap orientation times the goal's conjugate, (x, y, z, w)";
      n1 = "pen.body", p1 = "the pen body's grip point (left hand's), world frame (m)";
      n2 = "pen.cap", p2 = "the cap's grip point (right hand's), world frame (m)";
      break;
    case TableKind::kSwitch:
      what = "switch 1's rocker (the right hand's switch)";
      goal = "switch 1's rocker pose when pressed (on: the joint's upper limit)";
      rot = "switch 1 rocker orientation times the goal's conjugate, (x, y, z, w)";
      n1 = "switch1.pos", p1 = "switch 1's press point (right hand's), world frame (m)";
      n2 = "switch2.pos", p2 = "switch 2's press point (left hand's), world frame (m)";
      break;
    case TableKind::kPourWater:
      what = "the kettle";
      goal = "the pour target: the bucket's opening (current) with the kettle's start "
             "orientation";
      rot = "kettle orientation times the goal's conjugate, (x, y, z, w)";
      n1 = "kettle.handle", p1 = "the kettle's handle (right hand's), world frame (m)";
      n2 = "bucket.pos", p2 = "the centre of the bucket's opening (left hand's), world frame (m)";
      break;
  }
  add_object_obs(s.obs, "object", what);
  add_goal_obs(s.obs, "goal", goal, rot);
  s.obs.add(n1, 3, p1);
  s.obs.add(n2, 3, p2);
  s.agents = agents_per_hand(s.obs, s.act);
  auto term = [&](const char* n, const char* d) { s.reward_terms.push_back({n, d}); };
  switch (kind) {
    case TableKind::kSwingCup:
      term("reach_right", "-(sum of the right fingertips' distances to the right handle) (m)");
      term("reach_left", "-(sum of the left fingertips' distances to the left handle) (m)");
      term("rotation", "rot_scale / (theta + rot_eps) - rot_offset while both sums < gate, "
                       "theta the cup's rotation distance to the goal (rad)");
      break;
    case TableKind::kScissors:
      term("offset", "the constant reward.offset");
      term("reach_right", "-(sum of the right fingertips' distances to the right handle) (m)");
      term("reach_left", "-(sum of the left fingertips' distances to the left handle) (m)");
      term("opening", "angle_scale (angle_offset - |q - target_angle|) while both sums < gate, "
                      "q the scissors' joint angle (rad)");
      break;
    case TableKind::kPen:
      term("reach_right", "exp(-reach_scale x sum of the right fingertips' distances to the cap "
                          "point)");
      term("reach_left", "exp(-reach_scale x sum of the left fingertips' distances to the body "
                         "point)");
      term("separation", "separation_scale d - separation_offset while both sums < gate, d the "
                         "distance between the cap and body points (m)");
      break;
    case TableKind::kSwitch:
      term("offset", "the constant reward.offset");
      term("reach_right", "-(sum of the right fingertips' distances to switch 1's press point)");
      term("reach_left", "-(sum of the left fingertips' distances to switch 2's press point)");
      term("press", "press_scale (press_offset - d), d the summed distances of the press points "
                    "to their pressed positions (m)");
      break;
    case TableKind::kPourWater:
      term("offset", "the constant reward.offset");
      term("reach_right", "-(sum of the right fingertips' distances to the kettle handle) (m)");
      term("reach_left", "-(sum of the left fingertips' distances to the bucket opening) (m)");
      term("lift", "lift_scale min(h, lift_max) while both sums < gate, h the kettle's rise "
                   "above its start (m, >= 0); 0 by default (lift_scale 0)");
      term("pour", "pour_scale (pour_offset - d) while both sums < gate, d the spout's distance "
                   "to the bucket opening (m)");
      break;
  }
  return s;
}

std::unique_ptr<Task> make_table_task(TableKind kind, const TaskSpec& spec,
                                      const std::string& config_file) {
  return std::make_unique<TableTask>(kind, spec, load_table_params(config_file, kind));
}

// ---- objects as MJCF text -----------------------------------------------------------------

namespace {

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.8g", v);
  return buf;
}
std::string v3(double a, double b, double c) { return num(a) + " " + num(b) + " " + num(c); }

// A geom of an object: collides with the world (floor, table, other objects) and both hands.
struct GeomWriter {
  std::ostringstream& x;
  double density, friction;
  const char* rgba;
  void box(const std::string& name, sim::Vec3 half, sim::Vec3 pos, double fr = -1) {
    x << "      <geom name=\"" << name << "\" type=\"box\" size=\"" << v3(half[0], half[1], half[2])
      << "\" pos=\"" << v3(pos[0], pos[1], pos[2]) << "\"" << common(fr) << "/>\n";
  }
  void capsule(const std::string& name, double r, sim::Vec3 a, sim::Vec3 b, double fr = -1) {
    x << "      <geom name=\"" << name << "\" type=\"capsule\" size=\"" << num(r)
      << "\" fromto=\"" << v3(a[0], a[1], a[2]) << " " << v3(b[0], b[1], b[2]) << "\""
      << common(fr) << "/>\n";
  }
  std::string common(double fr) const {
    return " density=\"" + num(density) + "\" friction=\"" + num(fr < 0 ? friction : fr) +
           " 0.005 0.0001\" condim=\"4\" contype=\"1\" conaffinity=\"7\" rgba=\"" + rgba + "\"";
  }
};

void quat_of_rpy(double* q, const sim::Vec3& rpy) {
  const sim::Pose p = sim::Pose::rpy({0, 0, 0}, rpy[0], rpy[1], rpy[2]);
  for (int k = 0; k < 4; ++k) q[k] = p.quat[k];
}

void quat_axis(double* q, int axis, double angle) {
  double a[3] = {0, 0, 0};
  a[axis] = 1;
  math::axis_angle_quat(q, a, angle);
}

}  // namespace

// ---- task ---------------------------------------------------------------------------------

TableTask::TableTask(TableKind kind, const TaskSpec& spec, TableParams params)
    : BodyTask(spec, params.file), kind_(kind), p_(std::move(params)) {
  TableProgram& g = prog_;
  g.kind = kind;
  g.hand_dof_noise = p_.hand_dof_noise;
  g.reset_angle = p_.reset_angle;
  g.offset = p_.offset;
  g.gate = p_.gate;
  g.goal_scale = p_.goal_scale;
  g.goal_offset = p_.goal_offset;
  g.rot_eps = p_.rot_eps;
  g.reach_scale = p_.reach_scale;
  g.target_angle = p_.target_angle;
  g.success = p_.success;
  g.drop_height = p_.drop_height;
  g.max_reach = p_.max_reach;
  g.lift_scale = p_.lift_scale;
  g.lift_max = p_.lift_max;
  g.lift_from = p_.object.pos[2];
  g.t_offset = spec.term_index("offset");
  g.t_right = spec.term_index("reach_right");
  g.t_left = spec.term_index("reach_left");
  g.t_lift = spec.term_index("lift");
  g.t_goal = static_cast<int>(spec.reward_terms.size()) - 1;
}

sim::SceneBuilder TableTask::scene(const sim::HandSpec& right_hand,
                                   const sim::PhysicsOptions& physics) const {
  // water balls add contacts and constraint rows to the arena: under random actions 8 balls used
  // 105 KiB of it at most and 30 balls 417 KiB (README), about 14 KiB a ball; 32 KiB a ball
  // keeps the scene's margin over the use at 3.5x or more
  sim::PhysicsOptions ph = physics;
  if (kind_ == TableKind::kPourWater) ph.memory += (32 << 10) * p_.water_count;
  // and up to 156 constraint rows with the default 8 balls under random actions (bench task,
  // maxuse_efc), but up to 301 under ML20 ProMP's trained policy
  // (bench/results/gpu-meta-h100/ML20-promp-16384); contacts get a room raised alike
  if (kind_ == TableKind::kPourWater) ph = ph.with_gpu_room(448, 128);
  sim::SceneBuilder sb(ph);
  add_two_hands(sb, right_hand, p_.right, p_.left, sim::Base::kFree, spec().hands_collide);
  sim::TableSpec table;
  table.half_size = {p_.table_size[0] / 2, p_.table_size[1] / 2, p_.table_size[2] / 2};
  table.pose.pos = p_.table_pos;
  sb.add_table(table);

  auto object = [&](const std::string& name, const TableParams::Pose& at, bool free,
                    const std::string& body) {
    sim::ObjectSpec o;
    o.name = name;
    o.shape = sim::ObjectSpec::Shape::kMjcf;
    o.pose = sim::Pose::rpy(at.pos, at.rpy[0], at.rpy[1], at.rpy[2]);
    o.free = free;
    o.mjcf_body = body;
    sb.add_object(o);
  };
  const std::string damping = num(p_.joint_damping);
  std::ostringstream x;
  GeomWriter w{x, p_.density, p_.object_friction, "0.85 0.85 0.9 1"};
  switch (kind_) {
    case TableKind::kSwingCup: {
      // a cup 9 x 9 x 14 cm with a handle loop on each side (16.6 cm across the handles)
      w.box("cup_body", {0.045, 0.045, 0.07}, {0, 0, 0.07});
      for (int s : {1, -1}) {
        const std::string n = s > 0 ? "cup_right" : "cup_left";
        w.capsule(n + "_grip", 0.008, {s * g::kCupHandleX, 0, 0.04},
                  {s * g::kCupHandleX, 0, 0.10});
        w.box(n + "_lower", {0.015, 0.006, 0.006}, {s * 0.06, 0, 0.04});
        w.box(n + "_upper", {0.015, 0.006, 0.006}, {s * 0.06, 0, 0.10});
      }
      object("cup", p_.object, true, x.str());
      break;
    }
    case TableKind::kScissors: {
      // two flat halves about a pivot at the root's origin: blade (-x), shank and handle (+x);
      // the moving half carries the right handle (+y)
      auto half = [&](const std::string& n, double s) {
        w.box(n + "_blade", {0.11, 0.01, 0.003}, {-0.11, s * 0.004, 0});
        w.capsule(n + "_shank", 0.005, {0, 0, 0}, {0.12, s * 0.035, 0});
        w.box(n + "_handle", {0.035, 0.022, 0.005},
              {g::kScissorsHandleX, s * g::kScissorsHandleY, 0});
      };
      half("scissors_left", -1);
      double q[4];
      quat_axis(q, 2, g::kScissorsRest);
      x << "      <body name=\"scissors_moving\" pos=\"0 0 " << num(g::kScissorsLift)
        << "\" quat=\"" << num(q[0]) << " " << num(q[1]) << " " << num(q[2]) << " " << num(q[3])
        << "\">\n        <joint name=\"scissors_hinge\" type=\"hinge\" axis=\"0 0 1\" "
           "limited=\"true\" range=\""
        << num(g::kScissorsLower) << " " << num(g::kScissorsUpper) << "\" damping=\"" << damping
        << "\"/>\n";
      half("scissors_right", 1);
      x << "      </body>\n";
      object("scissors", p_.object, true, x.str());
      break;
    }
    case TableKind::kPen: {
      // a 36.4 cm pen along x: body capsule, cap capsule on a slide along +x
      w.capsule("pen_body", 0.011, {-0.17, 0, 0}, {0.05, 0, 0});
      x << "      <body name=\"pen_cap\" pos=\"" << num(g::kPenCapX)
        << " 0 0\">\n        <joint name=\"pen_slide\" type=\"slide\" axis=\"1 0 0\" "
           "limited=\"true\" range=\"0 "
        << num(g::kPenTravel) << "\" damping=\"" << damping << "\"/>\n";
      GeomWriter wc{x, p_.density, p_.object_friction, "0.2 0.3 0.8 1"};
      wc.capsule("pen_cap", 0.013, {0, 0, 0}, {0.14, 0, 0});
      x << "      </body>\n";
      object("pen", p_.object, true, x.str());
      break;
    }
    case TableKind::kSwitch: {
      for (int i = 1; i <= 2; ++i) {
        const TableParams::Pose& at = i == 1 ? p_.object : p_.second;
        const std::string n = "switch" + std::to_string(i);
        // a 10 x 8 x 7 cm housing with a 2 x 6 x 2.5 cm pedestal on top
        std::ostringstream y;
        GeomWriter ws{y, p_.density, p_.object_friction, "0.3 0.3 0.32 1"};
        ws.box(n + "_housing", {0.05, 0.04, 0.035}, {0, 0, 0.035});
        ws.box(n + "_pedestal", {0.01, 0.03, 0.0125}, {0, 0, 0.0825});
        object(n, at, false, y.str());
        // the rocker (9 x 6 x 1.6 cm) is its own body on a hinge about y, 0.12 m above the
        // switch's origin (a child of the world, not of the housing, so that it collides with
        // housing and pedestal: they stop it if a hand forces it far past its limits; in its
        // travel it touches neither)
        double rq[4], tilt[4], hinge[3];
        quat_of_rpy(rq, at.rpy);
        quat_axis(tilt, 1, -g::kSwitchTilt);
        const double up[3] = {0, 0, g::kSwitchHingeZ};
        math::frame_point(hinge, at.pos.data(), rq, up);
        std::ostringstream z;
        z << "      <joint name=\"" << n
          << "_hinge\" type=\"hinge\" axis=\"0 1 0\" limited=\"true\" range=\"0 "
          << num(g::kSwitchOn) << "\" damping=\"" << damping << "\" armature=\""
          << num(g::kSwitchArmature) << "\"/>\n";
        GeomWriter wr{z, p_.density, p_.object_friction, "0.9 0.3 0.25 1"};
        wr.box(n + "_rocker", {0.045, 0.03, g::kSwitchPressZ}, {0, 0, 0});
        sim::ObjectSpec o;
        o.name = n + "_rocker";
        o.shape = sim::ObjectSpec::Shape::kMjcf;
        o.pose.pos = {hinge[0], hinge[1], hinge[2]};
        double q[4];
        math::mul_quat(q, rq, tilt);
        o.pose.quat = {q[0], q[1], q[2], q[3]};
        o.free = false;
        o.mjcf_body = z.str();
        sb.add_object(o);
      }
      break;
    }
    case TableKind::kPourWater: {
      // kettle: an open vessel 16 x 16 x 14 cm (6 mm walls), a handle loop at +x, a spout at -x
      w.box("kettle_bottom", {0.08, 0.08, 0.003}, {0, 0, 0.003});
      for (int s : {1, -1}) {
        w.box(std::string("kettle_wall_x") + (s > 0 ? "p" : "n"), {0.003, 0.08, 0.067},
              {s * 0.077, 0, 0.073});
        w.box(std::string("kettle_wall_y") + (s > 0 ? "p" : "n"), {0.074, 0.003, 0.067},
              {0, s * 0.077, 0.073});
      }
      w.capsule("kettle_grip", 0.01, {g::kKettleHandleX, 0, 0.04}, {g::kKettleHandleX, 0, 0.12});
      w.box("kettle_grip_lower", {0.035, 0.008, 0.006}, {0.115, 0, 0.04});
      w.box("kettle_grip_upper", {0.035, 0.008, 0.006}, {0.115, 0, 0.12});
      w.capsule("kettle_spout", 0.012, {-0.08, 0, 0.07}, {g::kSpoutX + 0.01, 0, g::kSpoutZ});
      object("kettle", p_.object, true, x.str());
      // bucket: an open box 11 x 11 x 15 cm (6 mm walls)
      std::ostringstream y;
      GeomWriter wb{y, p_.density, p_.object_friction, "0.55 0.6 0.7 1"};
      wb.box("bucket_bottom", {0.055, 0.055, 0.003}, {0, 0, 0.003});
      for (int s : {1, -1}) {
        wb.box(std::string("bucket_wall_x") + (s > 0 ? "p" : "n"), {0.003, 0.055, 0.072},
               {s * 0.052, 0, 0.078});
        wb.box(std::string("bucket_wall_y") + (s > 0 ? "p" : "n"), {0.049, 0.003, 0.072},
               {0, s * 0.052, 0.078});
      }
      object("bucket", p_.second, true, y.str());
      // water: balls in a pyramid (4 x 4, 3 x 3, 2 x 2, 1) on the kettle's floor
      double kq[4];
      quat_of_rpy(kq, p_.object.rpy);
      const double r = p_.water_radius, step = 2 * r + 0.001;
      int made = 0;
      for (int layer = 0; layer < 4 && made < p_.water_count; ++layer) {
        const int n = 4 - layer;
        for (int i = 0; i < n && made < p_.water_count; ++i)
          for (int j = 0; j < n && made < p_.water_count; ++j) {
            const double local[3] = {(i - (n - 1) / 2.0) * step, (j - (n - 1) / 2.0) * step,
                                     0.006 + r + 0.001 + layer * step};
            double wp[3];
            math::frame_point(wp, p_.object.pos.data(), kq, local);
            sim::ObjectSpec b;
            b.name = "water" + std::to_string(made++);
            b.shape = sim::ObjectSpec::Shape::kSphere;
            b.size = {r, 0, 0};
            b.mass = 1000 * 4.0 / 3.0 * M_PI * r * r * r;
            b.condim = 3;
            b.friction = 0.1;
            b.rgba = {0.3, 0.5, 0.95, 1};
            b.pose.pos = {wp[0], wp[1], wp[2]};
            sb.add_object(b);
          }
      }
      break;
    }
  }
  return sb;
}

void TableTask::bind(const sim::SimModel& model) {
  const mjModel* m = model.mj();
  TableProgram& pr = prog_;
  bind_two_hands(model, p_.force_scale, p_.torque_scale, pr.hands);
  auto body = [&](const char* n) {
    const int b = mj_name2id(m, mjOBJ_BODY, n);
    if (b < 0) throw ModelError(spec().id + ": the scene has no body '" + n + "'");
    return b;
  };
  auto joint = [&](int i, const char* n) {
    const int j = mj_name2id(m, mjOBJ_JOINT, n);
    if (j < 0) throw ModelError(spec().id + ": the scene has no joint '" + n + "'");
    pr.joint_qpos[i] = m->jnt_qposadr[j];
    pr.joint_dof[i] = m->jnt_dofadr[j];
  };
  // the reward points: body and point in its frame (right hand's, left hand's)
  auto point = [&](int h, int b, double x, double y, double z) {
    pr.point_body[h] = b;
    pr.point_local[h][0] = x;
    pr.point_local[h][1] = y;
    pr.point_local[h][2] = z;
  };
  auto goal_at = [&](double x, double y, double z) {
    pr.goal_at[0] = x;
    pr.goal_at[1] = y;
    pr.goal_at[2] = z;
  };
  int* b = pr.body;
  switch (kind_) {
    case TableKind::kSwingCup:
      b[0] = pr.obs_body = pr.compared_body = body("cup");
      point(0, b[0], g::kCupHandleX, 0, g::kCupHandleZ);
      point(1, b[0], -g::kCupHandleX, 0, g::kCupHandleZ);
      goal_at(p_.object.pos[0], p_.object.pos[1], p_.object.pos[2]);
      quat_axis(pr.goal_quat, 2, p_.goal_yaw);
      break;
    case TableKind::kScissors:
      b[0] = pr.obs_body = body("scissors");
      b[1] = pr.compared_body = body("scissors_moving");
      joint(0, "scissors_hinge");
      point(0, b[1], g::kScissorsHandleX, g::kScissorsHandleY, 0);
      point(1, b[0], g::kScissorsHandleX, -g::kScissorsHandleY, 0);
      goal_at(0, 0, g::kScissorsLift);
      quat_axis(pr.goal_quat, 2, g::kScissorsRest + p_.target_angle);
      break;
    case TableKind::kPen: {
      b[0] = pr.obs_body = body("pen");
      b[1] = pr.compared_body = body("pen_cap");
      joint(0, "pen_slide");
      point(0, b[1], g::kPenCapPoint, 0, 0);
      point(1, b[0], g::kPenBodyPoint, 0, 0);
      const double start = g::kPenCapX + g::kPenCapPoint - g::kPenBodyPoint;  // 0.18 m
      goal_at(g::kPenCapX + p_.success - start, 0, 0);
      break;
    }
    case TableKind::kSwitch:
      b[0] = body("switch1");
      b[1] = pr.obs_body = pr.compared_body = body("switch1_rocker");
      b[2] = body("switch2_rocker");
      b[3] = body("switch2");
      joint(0, "switch1_hinge");
      joint(1, "switch2_hinge");
      point(0, b[1], g::kSwitchPressX, 0, g::kSwitchPressZ);
      point(1, b[2], g::kSwitchPressX, 0, g::kSwitchPressZ);
      goal_at(0, 0, g::kSwitchHingeZ);
      quat_axis(pr.goal_quat, 1, g::kSwitchOn - g::kSwitchTilt);
      break;
    case TableKind::kPourWater:
      b[0] = pr.obs_body = pr.compared_body = body("kettle");
      b[1] = body("bucket");
      point(0, b[0], g::kKettleHandleX, 0, g::kKettleHandleZ);
      point(1, b[1], 0, 0, g::kBucketTop);
      quat_of_rpy(pr.goal_quat, p_.object.rpy);
      break;
  }
  pr.root_tree = m->body_rootid[pr.obs_body];
}

}  // namespace bidex::tasks
