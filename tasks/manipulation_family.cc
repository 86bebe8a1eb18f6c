#include "tasks/manipulation_family.h"

#include <cmath>
#include <cstdio>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/yaml.h"
#include "tasks/config_fields.h"
#include "tasks/math.h"

namespace bidex::tasks::manip {

// ---- config -------------------------------------------------------------------------------

namespace {
std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}
}  // namespace

CommonParams load_common(const YamlView& root, const std::string& file) {
  CommonParams c;
  c.file = file;
  c.episode_length = read_episode_length(root);
  read_hand_poses(root, &c.right, &c.left);
  read_base_scales(root, &c.force_scale, &c.torque_scale);
  return c;
}

BlockPair load_block_pair(const YamlView& b, const char* place_key) {
  b.allow_keys({"edge", "density", "friction", "rpy", "block1", "block2"});
  BlockPair p;
  p.edge = read_number(b, "edge", 0.01, 0.2, "an edge in [0.01, 0.2] m");
  p.density = read_number(b, "density", 1, 20000, "a density in [1, 20000] kg/m^3");
  p.friction = read_number(b, "friction", 0.01, 10, "a sliding friction in [0.01, 10]");
  p.rpy = read_vec3(b.child("rpy"));
  const char* names[2] = {"block1", "block2"};
  for (int i = 0; i < 2; ++i) {
    auto v = b.child(names[i]);
    v.allow_keys({"start", place_key});
    p.start[i] = read_vec3(v.child("start"));
    p.place[i] = read_vec3(v.child(place_key));
  }
  return p;
}

TableParams load_table(const YamlView& v) {
  v.allow_keys({"pos", "half_size", "friction"});
  TableParams t;
  t.pos = read_vec3(v.child("pos"));
  {
    auto h = v.child("half_size");
    t.half_size = read_vec3(h);
    for (double x : t.half_size)
      if (!(x > 0 && x <= 10)) h.fail("3 half sizes in (0, 10] m", h.repr());
  }
  t.friction = read_number(v, "friction", 0.01, 10, "a sliding friction in [0.01, 10]");
  return t;
}

// ---- spec ---------------------------------------------------------------------------------

TaskSpec spec_with_hands(std::string id, std::string paper_name, std::string original_name,
                         HumanAge age, Difficulty difficulty, std::string skill,
                         int episode_length) {
  TaskSpec s = two_hand_spec(std::move(id), std::move(paper_name), std::move(original_name),
                             std::move(age), difficulty, std::move(skill), episode_length,
                             true);
  return s;
}

// ---- objects ------------------------------------------------------------------------------

sim::Quat quat_rpy(const sim::Vec3& rpy) {
  return sim::Pose::rpy({0, 0, 0}, rpy[0], rpy[1], rpy[2]).quat;
}

sim::ObjectSpec cube(const std::string& name, double edge, double density, double friction,
                     const sim::Vec3& pos, const sim::Quat& quat) {
  sim::ObjectSpec o;
  o.name = name;
  o.shape = sim::ObjectSpec::Shape::kBox;
  o.size = {edge / 2, edge / 2, edge / 2};
  o.mass = density * edge * edge * edge;
  o.friction = friction;
  o.condim = 4;
  o.pose.pos = pos;
  o.pose.quat = quat;
  o.rgba = {0.85, 0.35, 0.25, 1};
  return o;
}

sim::ObjectSpec table(const std::string& name, const TableParams& t) {
  sim::ObjectSpec o;
  o.name = name;
  o.shape = sim::ObjectSpec::Shape::kBox;
  o.size = t.half_size;
  o.mass = 10;  // a welded body: its mass plays no part
  o.free = false;
  o.friction = t.friction;
  o.condim = 3;
  o.pose.pos = t.pos;
  o.rgba = {0.55, 0.42, 0.3, 1};
  return o;
}

sim::ObjectSpec marker_box(const std::string& name, double half, const sim::Vec3& pos,
                           const sim::Quat& quat, std::array<double, 4> rgba) {
  sim::ObjectSpec o;
  o.name = name;
  o.shape = sim::ObjectSpec::Shape::kBox;
  o.size = {half, half, half};
  o.marker = true;
  o.free = false;
  o.pose.pos = pos;
  o.pose.quat = quat;
  o.rgba = rgba;
  return o;
}

std::string geom(const std::string& name, const std::string& type, const std::string& size,
                 const sim::Vec3& pos, double density, double friction, const std::string& rgba) {
  std::string s = "<geom name=\"";
  s.append(name).append("\" type=\"").append(type).append("\" size=\"").append(size);
  s.append("\" pos=\"").append(num(pos[0])).append(" ").append(num(pos[1])).append(" ");
  s.append(num(pos[2])).append("\" density=\"").append(num(density));
  s.append("\" friction=\"").append(num(friction)).append(" 0.005 0.0001\" condim=\"4\"");
  s.append(" contype=\"1\" conaffinity=\"7\" rgba=\"").append(rgba).append("\"/>\n");
  return s;
}

// ---- task ---------------------------------------------------------------------------------

ManipTask::ManipTask(const TaskSpec& spec, CommonParams common)
    : Task(spec, common.file), c_(std::move(common)) {}

sim::SceneBuilder ManipTask::scene_with_hands(const sim::HandSpec& right_hand,
                                              const sim::PhysicsOptions& physics) const {
  sim::SceneBuilder sb(physics);
  add_two_hands(sb, right_hand, c_.right, c_.left, sim::Base::kFree, spec().hands_collide);
  return sb;
}

void ManipTask::bind_hands(const sim::SimModel& model, HandRig (&hands)[2]) const {
  bind_two_hands(model, c_.force_scale, c_.torque_scale, hands);
}

const sim::ObjectIndex& object_index(const sim::SimModel& model, const std::string& task,
                                     const std::string& name) {
  const sim::ObjectIndex* o = model.object(name);
  if (!o) throw ModelError(task + ": the scene lacks its object '" + name + "'");
  return *o;
}

}  // namespace bidex::tasks::manip
