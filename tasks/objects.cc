#include "tasks/objects.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/files.h"
#include "core/yaml.h"
#include "tasks/hands.h"
#include "tasks/math.h"
#include "tasks/object_body.h"

namespace bidex::tasks {

using Shape = sim::ObjectSpec::Shape;

void observe_object(const sim::SlotView& v, int body, int root_tree, float* out) {
  observe_object(world_rows(v), body, root_tree, out);
}

void add_object_obs(Layout& obs, const std::string& name, const std::string& what) {
  obs.add(name + ".pose", 7, what + ": position (m) and orientation (x, y, z, w), world frame");
  obs.add(name + ".linvel", 3, what + ": linear velocity (m/s), world frame");
  obs.add(name + ".angvel", 3, what + ": angular velocity (rad/s) x 0.2, world frame");
}

void add_goal_obs(Layout& obs, const std::string& name, const std::string& goal_doc,
                  const std::string& rot_doc) {
  obs.add(name + ".pose", 7, goal_doc + ": position (m) and orientation (x, y, z, w)", true);
  obs.add(name + ".rot_diff", 4,
          rot_doc.empty() ? "the object's orientation times the goal's conjugate (x, y, z, w): "
                            "the paper's goal rot - object rot"
                          : rot_doc,
          true);
}

void observe_goal(const double* goal, const double* object_quat, float* out) {
  observe_goal<double, double>(goal, object_quat, out);
}

double object_volume(const sim::ObjectSpec& o) {
  const auto& s = o.size;
  switch (o.shape) {
    case Shape::kBox: return 8 * s[0] * s[1] * s[2];
    case Shape::kSphere: return 4.0 / 3.0 * M_PI * s[0] * s[0] * s[0];
    case Shape::kCapsule: return M_PI * s[0] * s[0] * 2 * s[1] + 4.0 / 3.0 * M_PI * s[0] * s[0] * s[0];
    case Shape::kEllipsoid: return 4.0 / 3.0 * M_PI * s[0] * s[1] * s[2];
    case Shape::kMjcf: return 0;
  }
  return 0;
}

double bounding_radius(const sim::ObjectSpec& o) {
  const auto& s = o.size;
  switch (o.shape) {
    case Shape::kBox: return std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    case Shape::kSphere: return s[0];
    case Shape::kCapsule: return s[0] + s[1];
    case Shape::kEllipsoid: return std::max({s[0], s[1], s[2]});
    case Shape::kMjcf: return 0;
  }
  return 0;
}

ObjectChoice object_preset(const std::string& type, const std::string& file,
                           const std::string& key) {
  ObjectChoice c;
  c.type = type;
  c.density = 500;  // the original's asset density
  auto& o = c.spec;
  o.condim = 4;
  o.friction = 1.0;
  if (type == "egg") {  // ellipsoid 6 x 6 x 8 cm, free-joint damping 0.01
    o.shape = Shape::kEllipsoid;
    o.size = {0.03, 0.03, 0.04};
    o.damping = 0.01;
    o.rgba = {0.95, 0.9, 0.75, 1};
  } else if (type == "block") {  // 5 cm cube
    o.shape = Shape::kBox;
    o.size = {0.025, 0.025, 0.025};
    o.rgba = {0.3, 0.6, 0.9, 1};
  } else if (type == "pen") {  // capsule radius 8 mm, 20 cm between the cap centres
    o.shape = Shape::kCapsule;
    o.size = {0.008, 0.1, 0};
    o.damping = 0.01;  // as the egg: a thin capsule can otherwise spin up about its axis
    o.rgba = {0.2, 0.2, 0.7, 1};
  } else if (type == "ball") {  // 7 cm ball (not in the original; our choice)
    o.shape = Shape::kSphere;
    o.size = {0.035, 0, 0};
    o.rgba = {0.9, 0.35, 0.3, 1};
  } else if (type == "mjcf") {
    o.shape = Shape::kMjcf;
    c.density = 0;
  } else {
    throw ConfigError(file, key, "one of egg, block, pen, ball, mjcf", "'" + type + "'");
  }
  if (o.shape != Shape::kMjcf) o.mass = c.density * object_volume(o);
  return c;
}

namespace {
std::string folder_of(const std::string& path) {
  auto slash = path.rfind('/');
  return slash == std::string::npos ? "." : path.substr(0, slash);
}
}  // namespace

ObjectChoice parse_object(const YamlView& v) {
  if (!v.is_map()) return object_preset(v.as<std::string>(), v.file(), v.path());
  v.allow_keys({"type", "size", "density", "friction", "file"});
  const auto type_view = v.child("type");
  ObjectChoice c = object_preset(type_view.as<std::string>(), v.file(), type_view.path());
  auto& o = c.spec;
  if (c.type == "mjcf") {
    const auto fv = v.child("file");
    std::string f = fv.as<std::string>();
    if (f.empty()) fv.fail("a file name", "''");
    if (f[0] != '/') f = folder_of(v.file()) + "/" + f;
    c.file = f;
    try {
      o.mjcf_body = "<!-- object body from " + f + " -->\n" + read_file(f);
    } catch (const IoError& e) {
      throw ConfigError(v.file(), fv.path(), "a readable MJCF body file", e.what());
    }
    for (const char* k : {"size", "density"})
      if (v.has(k)) v.child(k).fail("no '" + std::string(k) + "' for an mjcf object (its geoms set it)", v.child(k).repr());
  } else {
    if (v.has("file")) v.child("file").fail("'file' only with type: mjcf", v.child("file").repr());
    if (auto s = v.maybe("size")) {
      auto xs = s->as<std::vector<double>>();
      const size_t want = o.shape == Shape::kSphere ? 1 : o.shape == Shape::kCapsule ? 2 : 3;
      if (xs.size() != want)
        s->fail(std::to_string(want) + " numbers (" +
                    (want == 1 ? "radius" : want == 2 ? "radius, half length" : "half sizes") + ")",
                s->repr());
      for (double x : xs)
        if (!(x > 0)) s->fail("sizes > 0 (metres)", s->repr());
      for (size_t k = 0; k < 3; ++k) o.size[k] = k < xs.size() ? xs[k] : 0.0;
    }
    if (auto d = v.maybe("density")) {
      c.density = d->as<double>();
      if (!(c.density > 0)) d->fail("a density > 0 (kg/m^3)", d->repr());
    }
    o.mass = c.density * object_volume(o);
  }
  if (auto fr = v.maybe("friction")) {
    o.friction = fr->as<double>();
    if (!(o.friction >= 0)) fr->fail("a friction coefficient >= 0", fr->repr());
  }
  return c;
}

sim::ObjectSpec goal_marker(const ObjectChoice& object, const std::string& name) {
  sim::ObjectSpec g = object.spec;
  g.name = name;
  g.marker = true;
  g.free = false;
  g.mjcf_body.clear();
  if (g.shape == Shape::kMjcf) {
    g.shape = Shape::kSphere;
    g.size = {0.02, 0, 0};
  }
  g.rgba = {0.2, 0.85, 0.3, 0.35};
  return g;
}

}  // namespace bidex::tasks
