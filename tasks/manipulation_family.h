// Shared pieces of the table-top manipulation tasks bottle_cap, push_block, block_stack,
// re_orientation and grasp_and_place (each in its own folder, with a README of its decisions):
// both hands on free bases, the YAML sections they share (episode length, hand mounts, base
// scales), objects built from primitive geoms, and the hand half of actions and observations.
#pragma once

#include <string>
#include <vector>

#include "tasks/config_fields.h"
#include "tasks/hands.h"
#include "tasks/objects.h"
#include "tasks/task.h"

namespace bidex {
class YamlView;
}

namespace bidex::tasks::manip {

using tasks::HandPose;  // roll, pitch, yaw (rad): R = Rz(yaw) Ry(pitch) Rx(roll)

// The YAML keys every task of the family has: episode_length, hands {right, left}, base
// {force_scale, torque_scale}.
struct CommonParams {
  std::string file;
  int episode_length = 0;
  HandPose right, left;
  double force_scale = 0, torque_scale = 0;  // x 1e5/60 N and x 1e3/60 N m at action 1
};

// Strict readers (ConfigError naming file, key, expected and actual value).
CommonParams load_common(const YamlView& root, const std::string& file);

// A table: a welded box (centre pose, half sizes) with its own sliding friction.
struct TableParams {
  sim::Vec3 pos{}, half_size{};
  double friction = 1;
};
TableParams load_table(const YamlView& v);

// Two cubes: `blocks: {edge, density, friction, rpy, block1: {start, <place_key>}, block2: ...}`,
// `place` being each block's goal or target position.
struct BlockPair {
  double edge = 0.05, density = 500, friction = 1;  // m, kg/m^3, sliding friction
  sim::Vec3 rpy{};                                  // start orientation of both blocks
  sim::Vec3 start[2]{}, place[2]{};                 // block1, block2
};
BlockPair load_block_pair(const YamlView& blocks, const char* place_key);

// Geometry: the spec's hand slices (free bases), then the task adds its tail.
TaskSpec spec_with_hands(std::string id, std::string paper_name, std::string original_name,
                         HumanAge age, Difficulty difficulty, std::string skill,
                         int episode_length);

// Object builders (collision bits as the scene builder's objects: contype 1, conaffinity 7).
// A free cube of edge `edge`, mass density * edge^3.
sim::ObjectSpec cube(const std::string& name, double edge, double density, double friction,
                     const sim::Vec3& pos, const sim::Quat& quat);
// A welded table box.
sim::ObjectSpec table(const std::string& name, const TableParams& t);
// A translucent, never-colliding marker box (a mocap body).
sim::ObjectSpec marker_box(const std::string& name, double half, const sim::Vec3& pos,
                           const sim::Quat& quat, std::array<double, 4> rgba);
// One <geom> line of MJCF text for kMjcf objects (type box/capsule/sphere, size values as
// written, position in the body frame), with density and friction.
std::string geom(const std::string& name, const std::string& type, const std::string& size,
                 const sim::Vec3& pos, double density, double friction,
                 const std::string& rgba = "0.8 0.8 0.85 1");
// (w, x, y, z) of R = Rz(yaw) Ry(pitch) Rx(roll).
sim::Quat quat_rpy(const sim::Vec3& rpy);

// Base of the family's tasks: two free-base hands placed by the YAML. Each task's stages are
// the bodies of its program (tasks/<id>/<id>_body.h), which holds both hands' rigs (the paper's
// action order and the hand blocks of the observation, tasks/hand_body.h).
class ManipTask : public Task {
 public:
  ManipTask(const TaskSpec& spec, CommonParams common);
  int episode_length() const override { return c_.episode_length; }
  const CommonParams& common() const { return c_; }

 protected:
  // Hands placed at their mounts.
  sim::SceneBuilder scene_with_hands(const sim::HandSpec& right_hand,
                                     const sim::PhysicsOptions& physics) const;
  // Both hands' rigs (right, left) with the YAML's base scales.
  void bind_hands(const sim::SimModel& model, HandRig (&hands)[2]) const;

  CommonParams c_;
};
// Object index of a named object in a compiled scene (throws ModelError when absent).
const sim::ObjectIndex& object_index(const sim::SimModel& model, const std::string& task,
                                     const std::string& name);

}  // namespace bidex::tasks::manip
