// The two-handle family (lift_underarm and the four door tasks): one object with a right and a
// left handle; each hand is rewarded for staying at its handle and both together for moving the
// object to its goal (the pot to a point above the table, the door leaves apart or together).
// The five tasks share this code and differ only in their spec and their YAML (each task's own
// folder holds both, and a README with every decision). The objects are built here from
// primitives: a pot (four box bars as an octagonal body, two handle boxes) on a table, or a
// double door (a fixed frame and two hinged leaves with bar handles).
#pragma once

#include <memory>
#include <string>

#include "tasks/config_fields.h"
#include "tasks/handle_body.h"
#include "tasks/hands.h"
#include "tasks/task.h"
#include "tasks/body_task.h"

namespace bidex::tasks {

struct HandleParams {
  enum class Kind { kPot, kDoor };
  std::string file;          // the YAML it came from
  Kind kind = Kind::kPot;
  int episode_length = 250;  // control steps
  using HandPose = tasks::HandPose;  // roll, pitch, yaw (rad): R = Rz(yaw) Ry(pitch) Rx(roll)
  HandPose right, left;
  // free bases: action +-1 gives force_scale * 1e5 / 60 N and torque_scale * 1e3 / 60 N m
  double force_scale = 0, torque_scale = 0;

  // pot (lift_underarm): its start (origin 5 cm above its bottom), the table under it, the goal
  struct Pot {
    sim::Vec3 pos{};
    double mass = 3;                 // kg
    double friction = 3;             // body boxes (the handles keep 1)
    sim::Vec3 table_pos{}, table_half_size{};
    sim::Vec3 goal{};                // the target point of the pot's origin
  } pot;

  // door: a fixed frame at `pos` and two leaves on vertical hinges
  struct Door {
    sim::Vec3 pos{};
    bool inward = false;             // leaves open towards the hands (+x) instead of away (-x)
    double start_angle = 0;          // both leaves at every reset (rad, [0, pi/2])
    double handle_height = 0;        // handle point height relative to `pos` (m)
    double damping = 1;              // hinge damping (N m s/rad)
    double frictionloss = 0.2;       // hinge dry friction (N m)
    double density = 500;            // kg/m^3 of the leaves and handles
    double friction = 0.1;           // door geoms' sliding friction
  } door;

  // reward: constant - d_right - d_left + goal_weight (goal_offset - d_target); the variant
  // read ("original", "paper"; tasks/README.md, "Reward variants")
  std::string reward_variant;
  bool palm_distance = true;         // d_hand: palm point (true) or sum of 5 fingertip points
  bool target_y_gap = false;         // doors' d_target: |y_R - y_L| (true) or |h_R - h_L|
  double constant = 0.2;
  double goal_weight = 3, goal_offset = 0.985;
  double goal_gate = 0;              // > 0: the goal term only while both d_hand < goal_gate
  // success: pot within success_distance of the goal; door: |y_R - y_L| of the handles above
  // (wider) or below (!wider) success_gap
  double success_distance = 0.05;
  double success_gap = 0.5;
  bool success_wider = true;
  // termination
  double drop_height = -1e9;         // pot origin at or below it
  double max_hand_distance = 0;      // either d_hand at or above it (0: off)
};

// Reads a family YAML strictly (unknown keys, missing fields, wrong types and impossible values
// are ConfigErrors naming file, key, expected and actual value).
HandleParams load_handle_params(const std::string& file, const TaskSpec& spec);

// The spec of a family member: layouts (the paper's tables: two free hands, the object block,
// the goal block, right then left handle), agents and reward terms; `version` as TaskSpec's.
TaskSpec handle_family_spec(std::string id, std::string paper_name, std::string original_name,
                            HumanAge age, Difficulty difficulty, std::string skill,
                            int episode_length, const std::string& object, int version = 1);

std::unique_ptr<Task> make_handle_task(const TaskSpec& spec, const std::string& config_file);

// Defines a family member's <id>_spec() and make_<id>() (declared in registry.h).
#define BIDEX_DEFINE_HANDLE_TASK(id, ...)                                         \
  const TaskSpec& id##_spec() {                                                   \
    static const TaskSpec spec = handle_family_spec(#id, __VA_ARGS__);            \
    return spec;                                                                  \
  }                                                                               \
  std::unique_ptr<Task> make_##id(const std::string& config_file) {               \
    return make_handle_task(id##_spec(), config_file);                            \
  }

// Fixed geometry of the built objects (metres; tasks/<id>/README.md).
namespace handle_geometry {
// pot: octagonal body 0.22 m across the flats, 0.166 m tall, bottom 0.05 m below the origin;
// handle points at (0, +-0.15, 0.06) in the pot frame (right handle on +y)
constexpr double kPotHalfWidth = 0.11, kPotHalfHeight = 0.083, kPotBottom = -0.05;
constexpr double kPotHandleY = 0.15, kPotHandleZ = 0.06;
// door: hinges at y = +-0.42 (right leaf on +y), leaves 0.415 x 0.93 x 0.02 m, handle points
// 0.39 m from the hinge towards the middle and 0.04 m in front of the hinge plane (+x)
constexpr double kHingeY = 0.42, kLeafWidth = 0.415, kLeafHeight = 0.93, kLeafThick = 0.02;
constexpr double kHandleFromHinge = 0.39, kHandleOut = 0.04;
}  // namespace handle_geometry

BIDEX_STAGE_BODIES(Handle, HandleProgram, handle_);

class HandleTask : public BodyTask<Task, HandleBodies> {
 public:
  HandleTask(const TaskSpec& spec, HandleParams params);

  const HandleParams& params() const { return p_; }
  int episode_length() const override { return p_.episode_length; }
  sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                          const sim::PhysicsOptions& physics) const override;
  void bind(const sim::SimModel& model) override;

  // World positions of the right (h = 0) and left (h = 1) handle points.
  void handle_point(const sim::SlotView& v, int h, double* out) const;
  // The reward's d_hand of hand h (0 right, 1 left) to its handle.
  double hand_distance(const sim::SlotView& v, int h) const;
  // The reward's d_target: pot to goal, or handle to handle.
  double target_distance(const TaskSlot& slot) const;
  // Door leaves' hinge qpos / dof addresses (right, left); -1 for the pot.
  int hinge_qpos(int h) const { return prog_.hinge_qpos[h]; }
  int hinge_dof(int h) const { return prog_.hinge_dof[h]; }
  const HandRig& hand(int h) const { return prog_.hands[h]; }

 private:
  HandleParams p_;
};

}  // namespace bidex::tasks
