// grasp_and_place: the spec, the YAML, the scene and the host half of GraspAndPlace
// (grasp_and_place.h).
#include <algorithm>
#include <cmath>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "core/yaml.h"
#include "tasks/grasp_and_place/grasp_and_place.h"
#include "tasks/math.h"
#include "tasks/registry.h"

namespace bidex::tasks {

namespace {

GraspAndPlaceParams load(const std::string& file) {
  const YamlView root = YamlView::load_file(file);
  root.allow_keys({"episode_length", "hands", "base", "table", "bucket", "object", "reward",
                   "termination"});
  GraspAndPlaceParams p;
  p.common = manip::load_common(root, file);
  p.table = manip::load_table(root.child("table"));
  {
    auto b = root.child("bucket");
    b.allow_keys({"half_width", "height", "wall", "density", "friction", "start"});
    p.bucket_half_width = read_number(b, "half_width", 0.02, 0.5, "a half width in [0.02, 0.5] m");
    p.bucket_height = read_number(b, "height", 0.02, 1, "a height in [0.02, 1] m");
    p.bucket_wall = read_number(b, "wall", 0.001, 0.05, "a wall thickness in [0.001, 0.05] m");
    if (!(2 * p.bucket_wall < p.bucket_half_width))
      b.child("wall").fail("a wall thinner than half the bucket's half width", b.child("wall").repr());
    p.bucket_density = read_number(b, "density", 1, 20000, "a density in [1, 20000] kg/m^3");
    p.bucket_friction = read_number(b, "friction", 0.01, 10, "a sliding friction in [0.01, 10]");
    p.bucket_start = read_vec3(b.child("start"));
  }
  {
    auto o = root.child("object");
    o.allow_keys({"shape", "size", "density", "friction", "start", "rpy"});
    auto s = o.child("shape");
    p.object_shape = s.as<std::string>();
    if (p.object_shape != "block" && p.object_shape != "ball") s.fail("block or ball", s.repr());
    p.object_size = read_number(o, "size", 0.01, 0.2, "an edge or diameter in [0.01, 0.2] m");
    p.object_density = read_number(o, "density", 1, 20000, "a density in [1, 20000] kg/m^3");
    p.object_friction = read_number(o, "friction", 0.01, 10, "a sliding friction in [0.01, 10]");
    p.object_start = read_vec3(o.child("start"));
    p.object_rpy = read_vec3(o.child("rpy"));
  }
  {
    auto r = root.child("reward");
    r.allow_keys({"decay", "place_scale", "success_tolerance"});
    p.decay = read_number(r, "decay", 0, 1000, "a rate in [0, 1000] 1/m");
    p.place_scale = read_number(r, "place_scale", 0, 1000, "a scale in [0, 1000]");
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

// The bucket's geoms: a floor and four walls, origin at the bucket's centre.
std::string bucket_body(const GraspAndPlaceParams& p) {
  const double w = p.bucket_half_width, h = p.bucket_height / 2, t = p.bucket_wall / 2;
  auto sz = [](double a, double b, double c) {
    return std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(c);
  };
  const double rho = p.bucket_density, mu = p.bucket_friction;
  const std::string c = "0.35 0.55 0.75 1";
  std::string s;
  s += manip::geom("bucket_floor", "box", sz(w, w, t), {0, 0, -h + t}, rho, mu, c);
  s += manip::geom("bucket_wall_px", "box", sz(t, w, h), {w - t, 0, 0}, rho, mu, c);
  s += manip::geom("bucket_wall_nx", "box", sz(t, w, h), {-(w - t), 0, 0}, rho, mu, c);
  s += manip::geom("bucket_wall_py", "box", sz(w - 2 * t, t, h), {0, w - t, 0}, rho, mu, c);
  s += manip::geom("bucket_wall_ny", "box", sz(w - 2 * t, t, h), {0, -(w - t), 0}, rho, mu, c);
  return s;
}

TaskSpec make_spec() {
  TaskSpec s = manip::spec_with_hands(
      "grasp_and_place", "Pull a Ball into Bucket (Grasp & Place)", "ShadowHandGraspAndPlace",
      HumanAge{22, 28, "22-28", false}, Difficulty::kMedium,
      "Places 10 pellets in a bottle in 60 seconds or less, one pellet at a time.", 500);
  add_object_obs(s.obs, "bucket", "the bucket");
  s.obs.add("bucket_link.pos", 3, "the bucket link's position (m): the bucket body's centre");
  s.obs.add("bucket_link.quat", 4, "the bucket link's orientation (x, y, z, w)");
  s.obs.add("object.pos", 3, "the object's position (m)");
  s.obs.add("object.quat", 4, "the object's orientation (x, y, z, w)");
  s.hands_collide = false;  // the original's collision filter -1: its hands pass through each other
  s.agents = agents_per_hand(s.obs, s.act);
  s.reward_terms = {
      {"right_hand", "exp(-decay d_right), d_right the right fingertips' distance sum to the bucket (m)"},
      {"left_hand", "exp(-decay d_left), d_left the left fingertips' distance sum to the object (m)"},
      {"place", "place_scale exp(-decay |bucket - object|)"},
  };
  return s;
}

}  // namespace

GraspAndPlace::GraspAndPlace(const TaskSpec& spec, GraspAndPlaceParams p)
    : BodyTask(spec, p.common), p_(std::move(p)) {
  GraspAndPlaceProgram& g = prog_;
  g.decay = p_.decay;
  g.place_scale = p_.place_scale;
  g.success_tolerance = p_.success_tolerance;
  g.max_tip_distance = p_.max_tip_distance;
  g.t_right = spec.term_index("right_hand");
  g.t_left = spec.term_index("left_hand");
  g.t_place = spec.term_index("place");
}

sim::SceneBuilder GraspAndPlace::scene(const sim::HandSpec& right_hand,
                                       const sim::PhysicsOptions& physics) const {
  // up to 203 constraint rows under random actions (bench task, maxuse_efc): more than the
  // default GPU room of 192, which every world overflowed (bench/results/warp-h100/)
  sim::SceneBuilder sb = scene_with_hands(right_hand, physics.with_gpu_room(384));
  sb.add_object(manip::table("table", p_.table));
  sim::ObjectSpec b;
  b.name = "bucket";
  b.shape = sim::ObjectSpec::Shape::kMjcf;
  b.mjcf_body = bucket_body(p_);
  b.pose.pos = p_.bucket_start;
  sb.add_object(b);
  const sim::Quat q = manip::quat_rpy(p_.object_rpy);
  auto o = manip::cube("object", p_.object_size, p_.object_density, p_.object_friction,
                       p_.object_start, q);
  if (p_.object_shape == "ball") {
    const double r = p_.object_size / 2;
    o.shape = sim::ObjectSpec::Shape::kSphere;
    o.size = {r, r, r};
    o.mass = p_.object_density * 4.0 / 3.0 * M_PI * r * r * r;
  }
  sb.add_object(o);
  return sb;
}

void GraspAndPlace::bind(const sim::SimModel& model) {
  bind_hands(model, prog_.hands);
  prog_.bucket = manip::object_index(model, spec().id, "bucket").body;
  prog_.object = manip::object_index(model, spec().id, "object").body;
  prog_.bucket_tree = model.mj()->body_rootid[prog_.bucket];
}

const TaskSpec& grasp_and_place_spec() {
  static const TaskSpec spec = make_spec();
  return spec;
}

std::unique_ptr<Task> make_grasp_and_place(const std::string& config_file) {
  return std::make_unique<GraspAndPlace>(grasp_and_place_spec(), load(config_file));
}

}  // namespace bidex::tasks
