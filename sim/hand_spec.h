// The hand description: a kinematic tree read from YAML (configs/hands/*.yaml) and validated.
// The scene builder turns it into MJCF; a left hand is the mirror image of a right one.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace bidex {
class YamlView;
}

namespace bidex::sim {

using Vec3 = std::array<double, 3>;
using Quat = std::array<double, 4>;  // (w, x, y, z), MuJoCo's order

enum class Side { kRight, kLeft };
const char* side_name(Side s);

// One collision primitive of a body, in the body frame (metres).
struct GeomSpec {
  enum class Type { kCapsule, kBox, kSphere };
  std::string name;
  Type type = Type::kCapsule;
  double radius = 0;      // capsule, sphere
  Vec3 from{}, to{};      // capsule end points
  Vec3 half{};            // box half sizes
  Vec3 pos{};             // box, sphere centre
  int condim = 3;         // contact dimensionality (3: sliding friction, 4: + torsional)
};

// The position actuator driving a joint: gain (N m/rad) and force limit (N m).
struct ActuatorSpec {
  double kp = 1;
  double force_limit = 1;
};

// A hinge joint between a body and its parent.
struct JointSpec {
  std::string name;                // paper name, e.g. FF3
  Vec3 axis{1, 0, 0};              // in the body frame
  double min_deg = 0, max_deg = 0; // joint range (degrees)
  double damping = 0;              // N m s/rad
  double armature = 0;             // kg m^2
  double frictionloss = 0;         // N m
  std::optional<ActuatorSpec> actuator;  // absent for coupled (passive) joints
};

// A site on a body; fingertip sites carry force and torque sensors.
struct SiteSpec {
  std::string name;
  Vec3 pos{};
  bool force_torque = false;
};

struct BodySpec {
  std::string name;
  std::string parent;    // empty for the root (forearm)
  Vec3 pos{};            // in the parent frame
  Quat quat{1, 0, 0, 0}; // in the parent frame
  double mass = 0;       // kg, spread over the body's geoms by volume
  std::optional<JointSpec> joint;
  std::vector<GeomSpec> geoms;
  std::vector<SiteSpec> sites;
};

// A passive joint that follows another: q_joint = ratio * q_follows (the paper's coupled distal
// joints; middle >= distal holds for ratio <= 1).
struct CouplingSpec {
  std::string joint, follows;
  double ratio = 1;
};

// Damping of the optional 6-DoF base (3 world-axis slides, 1 ball).
struct BaseSpec {
  double damping_translation = 0;  // N s/m
  double damping_rotation = 0;     // N m s/rad
};

struct HandSpec {
  std::string name;          // e.g. shadow
  std::string file;          // where it was read from (for messages)
  Side side = Side::kRight;  // the side that `bodies` describes
  Vec3 mount_euler_deg{};    // fixed rotation of the hand frame under its placement pose (xyz)
  BaseSpec base;
  std::vector<BodySpec> bodies;        // parents before children
  std::vector<CouplingSpec> couplings;
  std::vector<std::array<std::string, 2>> self_contacts;  // body pairs that may touch

  // Joints in tree order (the order of qpos and of the observation's 24 dof blocks).
  std::vector<const JointSpec*> joints() const;
  // Actuated joints in tree order (the order of the 20 joint actions).
  std::vector<const JointSpec*> actuated_joints() const;
  // Sites that carry force/torque sensors, in tree order (the fingertips).
  std::vector<const SiteSpec*> sensor_sites() const;
  const BodySpec* body(const std::string& name) const;
  const JointSpec* joint(const std::string& name) const;

  // The mirror image through the hand's sagittal plane (x -> -x in the hand frame), for the
  // other side. Joint signs keep their anatomical meaning (flexion stays positive).
  HandSpec mirrored() const;
  // This spec for `side` (itself or its mirror image).
  HandSpec for_side(Side s) const { return s == side ? *this : mirrored(); }
};

// Reads and validates a hand YAML; throws ConfigError naming file, key, expected and actual.
HandSpec load_hand_spec(const std::string& path);
HandSpec parse_hand_spec(const YamlView& root);

// The default hand spec file (configs/hands/shadow.yaml, found relative to the data folder).
std::string default_hand_path();

// The folder holding configs/ (BIDEX_DATA_DIR if set, else the source tree this was built from).
std::string data_dir();
// `path` as given where it opens from the working folder (or is absolute or empty); else, where
// it does, the same path below data_dir(): repository-relative paths in configs work from any
// folder.
std::string resolve_data_path(const std::string& path);

}  // namespace bidex::sim
