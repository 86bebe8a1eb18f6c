#include "sim/scene.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include <Eigen/Geometry>
#include <mujoco/mujoco.h>

#include "core/error.h"

namespace bidex::sim {

namespace {

// collision bits: world things (floor, tables, objects) = 1, right hand = 2, left hand = 4
constexpr int kWorldBit = 1;
int hand_bit(Side s) { return s == Side::kRight ? 2 : 4; }

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

template <class A>
std::string nums(const A& a) {
  std::string s;
  for (size_t i = 0; i < a.size(); ++i) {
    if (i) s += ' ';
    s += num(a[i]);
  }
  return s;
}

Eigen::Quaterniond to_eigen(const Quat& q) { return Eigen::Quaterniond(q[0], q[1], q[2], q[3]); }
Quat from_eigen(const Eigen::Quaterniond& q) {
  Eigen::Quaterniond n = q.normalized();
  return {n.w(), n.x(), n.y(), n.z()};
}

Eigen::Quaterniond euler_xyz_deg(const Vec3& e) {
  // MJCF's default euler sequence: intrinsic x, then y, then z
  const double k = M_PI / 180.0;
  return Eigen::AngleAxisd(e[0] * k, Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(e[1] * k, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(e[2] * k, Eigen::Vector3d::UnitZ());
}

double geom_volume(const GeomSpec& g) {
  switch (g.type) {
    case GeomSpec::Type::kSphere:
      return 4.0 / 3.0 * M_PI * std::pow(g.radius, 3);
    case GeomSpec::Type::kBox:
      return 8.0 * g.half[0] * g.half[1] * g.half[2];
    case GeomSpec::Type::kCapsule: {
      double len = std::hypot(g.to[0] - g.from[0], g.to[1] - g.from[1], g.to[2] - g.from[2]);
      return M_PI * g.radius * g.radius * len + 4.0 / 3.0 * M_PI * std::pow(g.radius, 3);
    }
  }
  return 0;
}

std::string geom_xml(const GeomSpec& g, const std::string& prefix, double mass, int contype,
                     int conaffinity, const char* rgba) {
  std::ostringstream x;
  x << "<geom name=\"" << prefix << g.name << "\" ";
  switch (g.type) {
    case GeomSpec::Type::kCapsule:
      x << "type=\"capsule\" size=\"" << num(g.radius) << "\" fromto=\"" << nums(g.from) << " "
        << nums(g.to) << "\"";
      break;
    case GeomSpec::Type::kBox:
      x << "type=\"box\" size=\"" << nums(g.half) << "\" pos=\"" << nums(g.pos) << "\"";
      break;
    case GeomSpec::Type::kSphere:
      x << "type=\"sphere\" size=\"" << num(g.radius) << "\" pos=\"" << nums(g.pos) << "\"";
      break;
  }
  x << " mass=\"" << num(mass) << "\" condim=\"" << g.condim << "\" contype=\"" << contype
    << "\" conaffinity=\"" << conaffinity << "\" rgba=\"" << rgba << "\"/>";
  return x.str();
}

void indent(std::ostringstream& x, int depth) { x << std::string(2 * depth, ' '); }

}  // namespace

Pose Pose::rpy(Vec3 pos, double roll, double pitch, double yaw) {
  Eigen::Quaterniond q = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                         Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                         Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
  return Pose{pos, from_eigen(q)};
}

std::string hand_prefix(Side s) { return s == Side::kRight ? "rh_" : "lh_"; }

SceneBuilder::SceneBuilder(PhysicsOptions physics) : physics_(std::move(physics)) {}

SceneBuilder& SceneBuilder::add_hand(const HandSpec& spec, const HandPlacement& where) {
  for (auto& h : hands_)
    if (h.where.side == where.side)
      throw ConfigError("", "scene.hands", "at most one hand per side",
                        std::string("a second ") + side_name(where.side) + " hand");
  hands_.push_back({spec.for_side(where.side), where});
  return *this;
}

SceneBuilder& SceneBuilder::add_object(const ObjectSpec& object) {
  for (auto& o : objects_)
    if (o.name == object.name)
      throw ConfigError("", "scene.objects", "unique object names", "'" + object.name + "' twice");
  objects_.push_back(object);
  return *this;
}

SceneBuilder& SceneBuilder::add_table(const TableSpec& table) {
  tables_.push_back(table);
  return *this;
}

SceneBuilder& SceneBuilder::set_floor(bool on) {
  floor_ = on;
  return *this;
}

SceneBuilder& SceneBuilder::set_hand_hand_contacts(bool on) {
  hand_hand_ = on;
  return *this;
}

std::string SceneBuilder::mjcf() const {
  const PhysicsOptions& p = physics_;
  std::ostringstream x;
  x << "<mujoco model=\"bidex\">\n";
  x << "  <compiler angle=\"radian\" inertiafromgeom=\"true\"/>\n";
  x << "  <option timestep=\"" << num(p.timestep) << "\" integrator=\"" << p.integrator
    << "\" solver=\"" << p.solver << "\" iterations=\"" << p.iterations << "\" tolerance=\""
    << num(p.tolerance) << "\" cone=\"" << p.cone << "\" jacobian=\"" << p.jacobian
    << "\">" << (p.refsafe ? "" : "<flag refsafe=\"disable\"/>") << "</option>\n";
  x << "  <size memory=\"" << p.memory << "\"/>\n";
  x << "  <visual><global offwidth=\"1280\" offheight=\"960\"/></visual>\n";
  // explicit <pair>s (the hands' self-contacts) do not take geom defaults: give them the same
  // softness, or they keep MuJoCo's own (solref 0.02), five times softer
  x << "  <default>\n    <geom solref=\"" << nums(p.contact_solref) << "\" solimp=\""
    << nums(p.contact_solimp) << "\" friction=\"1 0.005 0.0001\"/>\n    <pair solref=\""
    << nums(p.contact_solref) << "\" solimp=\"" << nums(p.contact_solimp) << "\"/>\n  </default>\n";
  x << "  <asset>\n    <texture name=\"grid\" type=\"2d\" builtin=\"checker\" width=\"256\" "
       "height=\"256\" rgb1=\".25 .28 .32\" rgb2=\".3 .33 .37\"/>\n"
       "    <material name=\"grid\" texture=\"grid\" texrepeat=\"8 8\"/>\n  </asset>\n";

  // world: light, floor, tables
  x << "  <worldbody>\n";
  x << "    <light name=\"top\" pos=\"0 -0.5 3\" dir=\"0 0 -1\" directional=\"true\"/>\n";
  if (floor_)
    x << "    <geom name=\"floor\" type=\"plane\" size=\"0 0 0.05\" material=\"grid\" contype=\""
      << kWorldBit << "\" conaffinity=\"" << kWorldBit << "\"/>\n";
  for (auto& t : tables_)
    x << "    <geom name=\"" << t.name << "\" type=\"box\" size=\"" << nums(t.half_size)
      << "\" pos=\"" << nums(t.pose.pos) << "\" quat=\"" << nums(t.pose.quat)
      << "\" rgba=\"0.55 0.42 0.3 1\" contype=\"" << kWorldBit << "\" conaffinity=\"" << kWorldBit
      << "\"/>\n";

  // hands: the spec's tree under a mount body at the placement pose
  for (auto& h : hands_) {
    const std::string pre = hand_prefix(h.where.side);
    int bit = hand_bit(h.where.side);
    int other = h.where.side == Side::kRight ? hand_bit(Side::kLeft) : hand_bit(Side::kRight);
    int contype = bit;
    int conaffinity = kWorldBit | (hand_hand_ ? other : 0);
    const char* rgba = h.where.side == Side::kRight ? "0.85 0.72 0.6 1" : "0.6 0.72 0.85 1";
    Eigen::Quaterniond mount = to_eigen(h.where.pose.quat) * euler_xyz_deg(h.spec.mount_euler_deg);
    Eigen::Quaterniond inv = mount.conjugate();

    // children of each body, in file order
    std::vector<std::vector<size_t>> kids(h.spec.bodies.size());
    for (size_t i = 1; i < h.spec.bodies.size(); ++i)
      for (size_t j = 0; j < i; ++j)
        if (h.spec.bodies[j].name == h.spec.bodies[i].parent) kids[j].push_back(i);

    // depth-first writer
    auto write_body = [&](auto&& self, size_t i, int depth) -> void {
      const BodySpec& b = h.spec.bodies[i];
      indent(x, depth);
      x << "<body name=\"" << pre << b.name << "\"";
      if (p.gravity_free_hands) x << " gravcomp=\"1\"";
      if (i == 0) {
        x << " pos=\"" << nums(h.where.pose.pos) << "\" quat=\"" << nums(from_eigen(mount)) << "\"";
      } else {
        x << " pos=\"" << nums(b.pos) << "\" quat=\"" << nums(b.quat) << "\"";
      }
      x << ">\n";
      if (i == 0 && h.where.base == Base::kFree) {
        // base: slides along the world axes (expressed in the body frame), then a ball joint
        const char* names[3] = {"base_x", "base_y", "base_z"};
        for (int k = 0; k < 3; ++k) {
          Eigen::Vector3d axis = inv * Eigen::Vector3d::Unit(k);
          indent(x, depth + 1);
          x << "<joint name=\"" << pre << names[k] << "\" type=\"slide\" axis=\"" << num(axis.x())
            << " " << num(axis.y()) << " " << num(axis.z()) << "\" damping=\""
            << num(h.spec.base.damping_translation) << "\" limited=\"false\"/>\n";
        }
        indent(x, depth + 1);
        x << "<joint name=\"" << pre << "base_rot\" type=\"ball\" damping=\""
          << num(h.spec.base.damping_rotation) << "\" limited=\"false\"/>\n";
      }
      if (b.joint) {
        const JointSpec& j = *b.joint;
        indent(x, depth + 1);
        x << "<joint name=\"" << pre << j.name << "\" type=\"hinge\" axis=\"" << nums(j.axis)
          << "\" limited=\"true\" range=\"" << num(j.min_deg * M_PI / 180) << " "
          << num(j.max_deg * M_PI / 180) << "\" damping=\"" << num(j.damping) << "\" armature=\""
          << num(j.armature) << "\" frictionloss=\"" << num(j.frictionloss) << "\"/>\n";
      }
      // the body's mass is spread over its geoms by volume
      double volume = 0;
      for (auto& g : b.geoms) volume += geom_volume(g);
      for (auto& g : b.geoms) {
        indent(x, depth + 1);
        x << geom_xml(g, pre, b.mass * geom_volume(g) / volume, contype, conaffinity, rgba) << "\n";
      }
      for (auto& s : b.sites) {
        indent(x, depth + 1);
        x << "<site name=\"" << pre << s.name << "\" pos=\"" << nums(s.pos)
          << "\" size=\"0.004\" rgba=\"1 0.2 0.2 0.6\"/>\n";
      }
      for (size_t k : kids[i]) self(self, k, depth + 1);
      indent(x, depth);
      x << "</body>\n";
    };
    write_body(write_body, 0, 2);
  }

  // objects
  for (auto& o : objects_) {
    if (o.marker && o.shape == ObjectSpec::Shape::kMjcf)
      throw ModelError("object '" + o.name + "': a goal marker must be a primitive shape, not MJCF");
    x << "    <body name=\"" << o.name << "\" pos=\"" << nums(o.pose.pos) << "\" quat=\""
      << nums(o.pose.quat) << "\"" << (o.marker ? " mocap=\"true\"" : "") << ">\n";
    if (o.free && !o.marker) {
      x << "      <joint name=\"" << o.name << "\" type=\"free\" damping=\"" << num(o.damping)
        << "\"/>\n";
    }
    std::string common = " mass=\"" + num(o.mass) + "\" condim=\"" + std::to_string(o.condim) +
                         "\" friction=\"" + num(o.friction) + " 0.005 0.0001\" rgba=\"" +
                         nums(o.rgba) + "\" contype=\"" +
                         std::to_string(o.marker ? 0 : kWorldBit) + "\" conaffinity=\"" +
                         std::to_string(o.marker ? 0 : (kWorldBit | 2 | 4)) + "\"" +
                         (o.marker ? " group=\"1\"" : "");
    switch (o.shape) {
      case ObjectSpec::Shape::kBox:
        x << "      <geom name=\"" << o.name << "\" type=\"box\" size=\"" << nums(o.size) << "\""
          << common << "/>\n";
        break;
      case ObjectSpec::Shape::kSphere:
        x << "      <geom name=\"" << o.name << "\" type=\"sphere\" size=\"" << num(o.size[0])
          << "\"" << common << "/>\n";
        break;
      case ObjectSpec::Shape::kCapsule:
        x << "      <geom name=\"" << o.name << "\" type=\"capsule\" size=\"" << num(o.size[0])
          << " " << num(o.size[1]) << "\"" << common << "/>\n";
        break;
      case ObjectSpec::Shape::kEllipsoid:
        x << "      <geom name=\"" << o.name << "\" type=\"ellipsoid\" size=\"" << nums(o.size)
          << "\"" << common << "/>\n";
        break;
      case ObjectSpec::Shape::kMjcf:
        x << o.mjcf_body << "\n";
        break;
    }
    x << "    </body>\n";
  }
  x << "  </worldbody>\n";

  // self-contact pairs of each hand (frictionless, as in the original)
  x << "  <contact>\n";
  for (auto& h : hands_) {
    const std::string pre = hand_prefix(h.where.side);
    for (auto& pair : h.spec.self_contacts) {
      const BodySpec* a = h.spec.body(pair[0]);
      const BodySpec* b = h.spec.body(pair[1]);
      for (auto& ga : a->geoms)
        for (auto& gb : b->geoms)
          x << "    <pair geom1=\"" << pre << ga.name << "\" geom2=\"" << pre << gb.name
            << "\" condim=\"1\"/>\n";
    }
  }
  x << "  </contact>\n";

  // couplings: distal = ratio * middle, as stiff equality constraints
  x << "  <equality>\n";
  for (auto& h : hands_) {
    const std::string pre = hand_prefix(h.where.side);
    for (auto& c : h.spec.couplings)
      x << "    <joint name=\"" << pre << c.joint << "_coupling\" joint1=\"" << pre << c.joint
        << "\" joint2=\"" << pre << c.follows << "\" polycoef=\"0 " << num(c.ratio)
        << " 0 0 0\" solref=\"" << nums(p.coupling_solref) << "\" solimp=\""
        << nums(p.coupling_solimp) << "\"/>\n";
  }
  x << "  </equality>\n";

  // position actuators with force limits; targets limited to the joint range
  x << "  <actuator>\n";
  for (auto& h : hands_) {
    const std::string pre = hand_prefix(h.where.side);
    for (auto* j : h.spec.actuated_joints())
      x << "    <position name=\"" << pre << j->name << "\" joint=\"" << pre << j->name
        << "\" kp=\"" << num(j->actuator->kp) << "\" ctrllimited=\"true\" ctrlrange=\""
        << num(j->min_deg * M_PI / 180) << " " << num(j->max_deg * M_PI / 180)
        << "\" forcelimited=\"true\" forcerange=\"" << num(-j->actuator->force_limit) << " "
        << num(j->actuator->force_limit) << "\"/>\n";
  }
  x << "  </actuator>\n";

  // force and torque at each fingertip site
  x << "  <sensor>\n";
  for (auto& h : hands_) {
    const std::string pre = hand_prefix(h.where.side);
    for (auto* s : h.spec.sensor_sites()) {
      x << "    <force name=\"" << pre << s->name << "_force\" site=\"" << pre << s->name
        << "\"/>\n";
      x << "    <torque name=\"" << pre << s->name << "_torque\" site=\"" << pre << s->name
        << "\"/>\n";
    }
  }
  x << "  </sensor>\n";
  x << "</mujoco>\n";
  return x.str();
}

SimModel SceneBuilder::build(const std::string& name) const {
  std::string text = mjcf();
  mjModel* m = compile_mjcf(text, name);

  auto id = [&](mjtObj type, const std::string& n) {
    int i = mj_name2id(m, type, n.c_str());
    if (i < 0) {
      mj_deleteModel(m);
      throw ModelError(name + ": compiled model lacks '" + n + "'");
    }
    return i;
  };

  // index tables of each hand
  std::vector<HandIndex> hands;
  for (auto& h : hands_) {
    HandIndex hi;
    hi.side = h.where.side;
    hi.prefix = hand_prefix(h.where.side);
    hi.free_base = h.where.base == Base::kFree;
    hi.root_body = id(mjOBJ_BODY, hi.prefix + h.spec.bodies[0].name);
    for (auto& b : h.spec.bodies) hi.bodies.push_back(id(mjOBJ_BODY, hi.prefix + b.name));
    auto joints = h.spec.joints();
    for (auto* j : joints) {
      int jid = id(mjOBJ_JOINT, hi.prefix + j->name);
      hi.joint_names.push_back(j->name);
      hi.joints.push_back(jid);
      hi.qpos_adr.push_back(m->jnt_qposadr[jid]);
      hi.dof_adr.push_back(m->jnt_dofadr[jid]);
    }
    for (size_t k = 0; k < joints.size(); ++k) {
      if (!joints[k]->actuator) continue;
      hi.actuators.push_back(id(mjOBJ_ACTUATOR, hi.prefix + joints[k]->name));
      hi.actuated.push_back(static_cast<int>(k));
    }
    for (auto* s : h.spec.sensor_sites()) {
      int sid = id(mjOBJ_SITE, hi.prefix + s->name);
      hi.tip_sites.push_back(sid);
      hi.tip_bodies.push_back(m->site_bodyid[sid]);
      hi.tip_force_adr.push_back(m->sensor_adr[id(mjOBJ_SENSOR, hi.prefix + s->name + "_force")]);
      hi.tip_torque_adr.push_back(
          m->sensor_adr[id(mjOBJ_SENSOR, hi.prefix + s->name + "_torque")]);
    }
    if (hi.free_base) {
      int jx = id(mjOBJ_JOINT, hi.prefix + "base_x");
      hi.base_qpos_adr = m->jnt_qposadr[jx];
      hi.base_dof_adr = m->jnt_dofadr[jx];
    }
    hands.push_back(std::move(hi));
  }

  // objects
  std::vector<ObjectIndex> objects;
  for (auto& o : objects_) {
    ObjectIndex oi;
    oi.name = o.name;
    oi.body = id(mjOBJ_BODY, o.name);
    if (o.marker) {
      oi.mocap = m->body_mocapid[oi.body];
    } else if (o.free) {
      int j = id(mjOBJ_JOINT, o.name);
      oi.qpos_adr = m->jnt_qposadr[j];
      oi.dof_adr = m->jnt_dofadr[j];
    }
    objects.push_back(oi);
  }
  return SimModel(m, std::move(text), physics_, std::move(hands), std::move(objects));
}

SceneBuilder two_hand_scene(const HandSpec& right, const PhysicsOptions& physics) {
  SceneBuilder sb(physics);
  sb.add_hand(right, {Side::kRight, Pose::rpy({0, 0, 0.5}, 0, 0, 0), Base::kFree});
  sb.add_hand(right, {Side::kLeft, Pose::rpy({0, -1.15, 0.5}, 0, 0, M_PI), Base::kFree});
  ObjectSpec egg;
  egg.name = "object";
  egg.shape = ObjectSpec::Shape::kEllipsoid;
  egg.size = {0.03, 0.03, 0.04};
  egg.mass = 0.075;
  egg.damping = 0.01;
  egg.pose.pos = {0, -0.39, 0.54};
  sb.add_object(egg);
  return sb;
}

}  // namespace bidex::sim
