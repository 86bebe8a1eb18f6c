// SceneBuilder: places hands, objects and tables by pose, writes MJCF text and compiles it from
// memory into a SimModel. The same text, written to a file, opens in MuJoCo's own tools.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "sim/hand_spec.h"
#include "sim/model.h"
#include "sim/physics.h"

namespace bidex::sim {

struct Pose {
  Vec3 pos{0, 0, 0};
  Quat quat{1, 0, 0, 0};  // (w, x, y, z)

  // From roll, pitch, yaw (radians) applied as R = Rz(yaw) Ry(pitch) Rx(roll).
  static Pose rpy(Vec3 pos, double roll, double pitch, double yaw);
};

enum class Base { kFixed, kFree };

struct HandPlacement {
  Side side = Side::kRight;
  Pose pose;                 // of the hand's mount; the spec's mount rotation is applied under it
  Base base = Base::kFixed;  // kFree adds 3 world-axis slides and a ball joint, damped
};

struct ObjectSpec {
  enum class Shape { kBox, kSphere, kCapsule, kEllipsoid, kMjcf };
  std::string name;
  Shape shape = Shape::kBox;
  // box: half sizes; sphere: radius in [0]; capsule: radius, half length; ellipsoid: semi-axes
  Vec3 size{0.025, 0.025, 0.025};
  double mass = 0.1;  // kg (ignored for kMjcf, whose geoms carry their own)
  Pose pose;
  bool free = true;           // a free joint; false welds it to the world
  // A goal marker: a mocap body that is only drawn (no joint, no contacts); tasks move it through
  // mjData::mocap_pos/mocap_quat. Primitive shapes only.
  bool marker = false;
  double damping = 0.0;       // free-joint damping
  double friction = 1.0;      // sliding friction
  int condim = 4;             // 3: sliding, 4: + torsional friction
  std::array<double, 4> rgba{0.9, 0.8, 0.6, 1.0};
  std::string mjcf_body;      // kMjcf: the inside of a <body> element (geoms, sites, bodies)
};

struct TableSpec {
  std::string name = "table";
  Vec3 half_size{0.3, 0.3, 0.2};
  Pose pose;  // centre of the box
};

class SceneBuilder {
 public:
  explicit SceneBuilder(PhysicsOptions physics = {});

  SceneBuilder& add_hand(const HandSpec& spec, const HandPlacement& where);
  SceneBuilder& add_object(const ObjectSpec& object);
  SceneBuilder& add_table(const TableSpec& table);
  SceneBuilder& set_floor(bool on);
  // Whether the right and left hands collide with each other (parts of one hand never do,
  // except the spec's self_contacts pairs).
  SceneBuilder& set_hand_hand_contacts(bool on);

  const PhysicsOptions& physics() const { return physics_; }
  // Standalone MJCF for everything added so far.
  std::string mjcf() const;
  // Compiles mjcf() from memory; throws ModelError (with MuJoCo's message) on failure.
  SimModel build(const std::string& name = "scene") const;

 private:
  struct PlacedHand {
    HandSpec spec;  // already for the placed side
    HandPlacement where;
  };
  PhysicsOptions physics_;
  std::vector<PlacedHand> hands_;
  std::vector<ObjectSpec> objects_;
  std::vector<TableSpec> tables_;
  bool floor_ = true;
  bool hand_hand_ = true;
};

// Name prefix of a hand's elements in a scene ("rh_" or "lh_").
std::string hand_prefix(Side s);

// The reference two-hand scene of the benchmarks and the physics study: both hands on free bases
// in the catch-underarm layout (right at (0, 0, 0.5), left at (0, -1.15, 0.5) turned to face it)
// and an egg (ellipsoid 3 x 3 x 4 cm, 75 g) above the right palm.
SceneBuilder two_hand_scene(const HandSpec& right, const PhysicsOptions& physics);

}  // namespace bidex::sim
