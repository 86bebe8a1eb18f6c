#include "sim/hand_spec.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/yaml.h"

namespace bidex::sim {

namespace {

std::string fmt(double v) {
  std::ostringstream ss;
  ss << v;
  return ss.str();
}

Quat axis_angle_deg(const YamlView& v) {
  auto a = v.as<std::array<double, 4>>();
  double n = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  if (n < 1e-12) v.fail("an axis-angle [x, y, z, degrees] with a non-zero axis", v.repr());
  double h = a[3] * M_PI / 360.0;
  double s = std::sin(h) / n;
  return {std::cos(h), a[0] * s, a[1] * s, a[2] * s};
}

Vec3 unit_axis(const YamlView& v) {
  auto a = v.as<Vec3>();
  double n = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  if (n < 1e-12) v.fail("a non-zero axis", v.repr());
  return {a[0] / n, a[1] / n, a[2] / n};
}

double positive(const YamlView& parent, const std::string& key, bool allow_zero) {
  auto v = parent.child(key);
  double x = v.as<double>();
  if (x < 0 || (!allow_zero && x == 0))
    v.fail(allow_zero ? "a number >= 0" : "a number > 0", fmt(x));
  return x;
}

double nonneg_opt(const YamlView& parent, const std::string& key, double fallback) {
  if (!parent.has(key)) return fallback;
  return positive(parent, key, /*allow_zero=*/true);
}

GeomSpec parse_geom(const YamlView& g) {
  GeomSpec out;
  out.name = g.req<std::string>("name");
  std::string type = g.req<std::string>("type");
  if (type == "capsule") {
    g.allow_keys({"name", "type", "radius", "from", "to", "condim"});
    out.type = GeomSpec::Type::kCapsule;
    out.radius = positive(g, "radius", false);
    out.from = g.req<Vec3>("from");
    out.to = g.req<Vec3>("to");
  } else if (type == "box") {
    g.allow_keys({"name", "type", "half", "pos", "condim"});
    out.type = GeomSpec::Type::kBox;
    out.half = g.req<Vec3>("half");
    for (double h : out.half)
      if (h <= 0) g.child("half").fail("three half sizes > 0", g.child("half").repr());
    out.pos = g.opt<Vec3>("pos", {0, 0, 0});
  } else if (type == "sphere") {
    g.allow_keys({"name", "type", "radius", "pos", "condim"});
    out.type = GeomSpec::Type::kSphere;
    out.radius = positive(g, "radius", false);
    out.pos = g.opt<Vec3>("pos", {0, 0, 0});
  } else {
    g.child("type").fail("one of capsule, box, sphere", "'" + type + "'");
  }
  out.condim = g.opt<int>("condim", 3);
  if (out.condim != 1 && out.condim != 3 && out.condim != 4 && out.condim != 6)
    g.child("condim").fail("1, 3, 4 or 6", std::to_string(out.condim));
  return out;
}

struct JointDefaults {
  double damping = 0, armature = 0, frictionloss = 0, kp = 1;
};

JointSpec parse_joint(const YamlView& j, const JointDefaults& d) {
  j.allow_keys({"name", "axis", "range_deg", "damping", "armature", "frictionloss", "actuator"});
  JointSpec out;
  out.name = j.req<std::string>("name");
  out.axis = unit_axis(j.child("axis"));
  auto rv = j.child("range_deg");
  auto r = rv.as<std::array<double, 2>>();
  if (!(r[0] < r[1])) rv.fail("min < max", "[" + fmt(r[0]) + ", " + fmt(r[1]) + "]");
  if (r[0] < -180 || r[1] > 180)
    rv.fail("a range inside [-180, 180] degrees", "[" + fmt(r[0]) + ", " + fmt(r[1]) + "]");
  out.min_deg = r[0];
  out.max_deg = r[1];
  out.damping = nonneg_opt(j, "damping", d.damping);
  out.armature = nonneg_opt(j, "armature", d.armature);
  out.frictionloss = nonneg_opt(j, "frictionloss", d.frictionloss);
  if (auto a = j.maybe("actuator")) {
    a->allow_keys({"kp", "force_limit"});
    ActuatorSpec act;
    act.kp = a->has("kp") ? positive(*a, "kp", false) : d.kp;
    act.force_limit = positive(*a, "force_limit", false);
    out.actuator = act;
  }
  return out;
}

}  // namespace

const char* side_name(Side s) { return s == Side::kRight ? "right" : "left"; }

std::string data_dir() {
  if (const char* env = std::getenv("BIDEX_DATA_DIR"); env && *env) return env;
  return BIDEX_SOURCE_DIR;
}

std::string resolve_data_path(const std::string& path) {
  if (path.empty() || path[0] == '/' || std::ifstream(path)) return path;
  const std::string in_data = data_dir() + "/" + path;
  return std::ifstream(in_data) ? in_data : path;
}

std::string default_hand_path() { return data_dir() + "/configs/hands/shadow.yaml"; }

HandSpec load_hand_spec(const std::string& path) {
  return parse_hand_spec(YamlView::load_file(path));
}

HandSpec parse_hand_spec(const YamlView& root) {
  root.expect_map();
  root.allow_keys({"name", "side", "mount_euler_deg", "joint_defaults", "base", "bodies",
                   "couplings", "self_contacts"});
  HandSpec spec;
  spec.file = root.file();
  spec.name = root.req<std::string>("name");
  std::string side = root.req<std::string>("side");
  if (side == "right") spec.side = Side::kRight;
  else if (side == "left") spec.side = Side::kLeft;
  else root.child("side").fail("right or left", "'" + side + "'");
  spec.mount_euler_deg = root.opt<Vec3>("mount_euler_deg", {0, 0, 0});

  // joint defaults apply where a joint leaves a value out
  JointDefaults jd;
  if (auto d = root.maybe("joint_defaults")) {
    d->allow_keys({"damping", "armature", "frictionloss", "kp"});
    jd.damping = nonneg_opt(*d, "damping", 0);
    jd.armature = nonneg_opt(*d, "armature", 0);
    jd.frictionloss = nonneg_opt(*d, "frictionloss", 0);
    jd.kp = d->has("kp") ? positive(*d, "kp", false) : 1.0;
  }

  auto base = root.child("base");
  base.allow_keys({"damping_translation", "damping_rotation"});
  spec.base.damping_translation = positive(base, "damping_translation", true);
  spec.base.damping_rotation = positive(base, "damping_rotation", true);

  // bodies: unique names, parents declared first
  std::set<std::string> body_names, joint_names, geom_names, site_names;
  for (auto& b : root.child("bodies").items()) {
    b.allow_keys({"name", "parent", "pos", "axisangle_deg", "mass", "joint", "geoms", "sites"});
    BodySpec body;
    body.name = b.req<std::string>("name");
    if (!body_names.insert(body.name).second)
      b.child("name").fail("a body name not used before", "'" + body.name + "' again");
    body.parent = b.opt<std::string>("parent", "");
    if (spec.bodies.empty() && !body.parent.empty())
      b.child("parent").fail("no parent for the first (root) body", "'" + body.parent + "'");
    if (!spec.bodies.empty()) {
      if (body.parent.empty()) b.fail("a 'parent' (only the first body is the root)", "none");
      if (!body_names.count(body.parent) || body.parent == body.name)
        b.child("parent").fail("the name of a body listed earlier", "'" + body.parent + "'");
    }
    body.pos = b.opt<Vec3>("pos", {0, 0, 0});
    if (auto aa = b.maybe("axisangle_deg")) body.quat = axis_angle_deg(*aa);
    body.mass = positive(b, "mass", false);
    if (auto j = b.maybe("joint")) {
      body.joint = parse_joint(*j, jd);
      if (!joint_names.insert(body.joint->name).second)
        j->child("name").fail("a joint name not used before", "'" + body.joint->name + "' again");
    }
    auto geoms = b.child("geoms");
    if (geoms.items().empty()) geoms.fail("at least one geom", "an empty list");
    for (auto& g : geoms.items()) {
      body.geoms.push_back(parse_geom(g));
      if (!geom_names.insert(body.geoms.back().name).second)
        g.child("name").fail("a geom name not used before", "'" + body.geoms.back().name + "'");
    }
    if (auto sites = b.maybe("sites")) {
      for (auto& s : sites->items()) {
        s.allow_keys({"name", "pos", "force_torque"});
        SiteSpec site;
        site.name = s.req<std::string>("name");
        if (!site_names.insert(site.name).second)
          s.child("name").fail("a site name not used before", "'" + site.name + "' again");
        site.pos = s.opt<Vec3>("pos", {0, 0, 0});
        site.force_torque = s.opt<bool>("force_torque", false);
        body.sites.push_back(site);
      }
    }
    spec.bodies.push_back(std::move(body));
  }
  if (spec.bodies.empty()) root.child("bodies").fail("at least one body", "an empty list");

  // couplings: a passive joint follows an actuated one
  if (auto cs = root.maybe("couplings")) {
    for (auto& c : cs->items()) {
      c.allow_keys({"joint", "follows", "ratio"});
      CouplingSpec cp;
      cp.joint = c.req<std::string>("joint");
      cp.follows = c.req<std::string>("follows");
      cp.ratio = c.opt<double>("ratio", 1.0);
      const JointSpec* j = spec.joint(cp.joint);
      const JointSpec* f = spec.joint(cp.follows);
      if (!j) c.child("joint").fail("the name of a joint of this hand", "'" + cp.joint + "'");
      if (!f) c.child("follows").fail("the name of a joint of this hand", "'" + cp.follows + "'");
      if (j->actuator)
        c.child("joint").fail("a joint without an actuator (it is driven by the coupling)",
                              "'" + cp.joint + "', which has one");
      if (!(cp.ratio > 0 && cp.ratio <= 1))
        c.child("ratio").fail("a ratio in (0, 1] (middle >= distal)", fmt(cp.ratio));
      spec.couplings.push_back(cp);
    }
  }
  // every joint is actuated or coupled
  for (auto* j : spec.joints()) {
    bool coupled = false;
    for (auto& c : spec.couplings) coupled = coupled || c.joint == j->name;
    if (!j->actuator && !coupled)
      root.child("bodies").fail("joint '" + j->name + "' to have an actuator or a coupling",
                                "neither");
  }

  if (auto sc = root.maybe("self_contacts")) {
    for (auto& p : sc->items()) {
      auto pair = p.as<std::vector<std::string>>();
      if (pair.size() != 2) p.fail("a pair of body names", p.repr());
      for (auto& n : pair)
        if (!body_names.count(n)) p.fail("names of bodies of this hand", "'" + n + "'");
      spec.self_contacts.push_back({pair[0], pair[1]});
    }
  }
  return spec;
}

std::vector<const JointSpec*> HandSpec::joints() const {
  std::vector<const JointSpec*> out;
  for (auto& b : bodies)
    if (b.joint) out.push_back(&*b.joint);
  return out;
}

std::vector<const JointSpec*> HandSpec::actuated_joints() const {
  std::vector<const JointSpec*> out;
  for (auto* j : joints())
    if (j->actuator) out.push_back(j);
  return out;
}

std::vector<const SiteSpec*> HandSpec::sensor_sites() const {
  std::vector<const SiteSpec*> out;
  for (auto& b : bodies)
    for (auto& s : b.sites)
      if (s.force_torque) out.push_back(&s);
  return out;
}

const BodySpec* HandSpec::body(const std::string& name) const {
  for (auto& b : bodies)
    if (b.name == name) return &b;
  return nullptr;
}

const JointSpec* HandSpec::joint(const std::string& name) const {
  for (auto& b : bodies)
    if (b.joint && b.joint->name == name) return &*b.joint;
  return nullptr;
}

HandSpec HandSpec::mirrored() const {
  // reflect points: x -> -x; rotation axes are pseudo-vectors: (x, y, z) -> (x, -y, -z)
  auto point = [](Vec3 p) { return Vec3{-p[0], p[1], p[2]}; };
  auto axis = [](Vec3 a) { return Vec3{a[0], -a[1], -a[2]}; };
  HandSpec m = *this;
  m.side = side == Side::kRight ? Side::kLeft : Side::kRight;
  for (auto& b : m.bodies) {
    b.pos = point(b.pos);
    b.quat = {b.quat[0], b.quat[1], -b.quat[2], -b.quat[3]};
    if (b.joint) b.joint->axis = axis(b.joint->axis);
    for (auto& g : b.geoms) {
      g.from = point(g.from);
      g.to = point(g.to);
      g.pos = point(g.pos);
    }
    for (auto& s : b.sites) s.pos = point(s.pos);
  }
  return m;
}

}  // namespace bidex::sim
