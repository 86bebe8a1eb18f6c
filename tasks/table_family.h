// The table family (swing_cup, scissors, pen, switch, pour_water): two free-base hands above a
// table that holds an articulated object built from primitives in code. The five tasks share
// this code and differ in their kind (object, reward points, goal, success) and their YAML
// (each task's folder holds its spec, its YAML and a README with every decision).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tasks/config_fields.h"
#include "tasks/hands.h"
#include "tasks/table_body.h"
#include "tasks/task.h"
#include "tasks/body_task.h"

namespace bidex::tasks {

struct TableParams {
  std::string file;                 // the YAML it came from
  int episode_length = 0;           // control steps
  using Pose = HandPose;  // pos, and rpy (rad): R = Rz(yaw) Ry(pitch) Rx(roll)
  Pose right, left;                 // hand mounts
  Pose object;                      // the object's root at the reset (switch: switch 1)
  Pose second;                      // switch 2 (switch), the bucket (pour_water); unused else
  sim::Vec3 table_pos{}, table_size{};  // table centre and full size (m)
  // object
  double object_friction = 1;       // sliding friction of the object's geoms
  double joint_damping = 0;         // the object's hinge or slide (N m s/rad or N s/m)
  double density = 500;             // kg/m^3 of the object's geoms
  int water_count = 0;              // pour_water: balls of water in the kettle
  double water_radius = 0.005;      // m
  // reset
  double hand_dof_noise = 0;        // fraction of the joint range (see sample_joint_noise)
  double reset_angle = 0;           // scissors: the joint's start angle (rad)
  // free bases: action +-1 gives force_scale * 1e5 / 60 N and torque_scale * 1e3 / 60 N m
  double force_scale = 0, torque_scale = 0;
  // reward (which are used depends on the kind; README of each task); the variant read
  // ("original", "paper", pour_water's "bidex", or "" where the task has one formula;
  // tasks/README.md)
  std::string reward_variant;
  double offset = 0;                // the constant term
  double gate = 0;                  // fingertip-distance sums below which the goal term pays
  double goal_scale = 0;            // the goal term's factor
  double goal_offset = 0;           // the goal term's constant
  double rot_eps = 0.1;             // swing_cup: 1 / (theta + rot_eps)
  double reach_scale = 10;          // pen: exp(-reach_scale x distance sum)
  double goal_yaw = 0;              // swing_cup: the goal orientation, yaw about world z
  double target_angle = 0;          // scissors: the joint's goal angle
  double success = 0;               // the success threshold (units per kind)
  // pour_water: lift_scale x (the kettle's rise above its start, capped at lift_max) (1/m, m)
  double lift_scale = 0, lift_max = 0;
  // termination
  double drop_height = 0;           // swing_cup, pour_water: the object (point) at or below it
  double max_reach = 0;             // scissors, pen: a fingertip-distance sum at or above it
};

// Reads a table-family YAML strictly (unknown keys, missing fields, wrong types and impossible
// values are ConfigErrors naming file, key, expected and actual value).
TableParams load_table_params(const std::string& file, TableKind kind);

// The spec of a family member: the paper's layout (two 199-wide hand blocks, object 13, goal
// 7 + 4, two points 3 + 3 = 428) and the reward terms of its kind.
TaskSpec table_family_spec(TableKind kind, std::string id, std::string paper_name,
                           std::string original_name, HumanAge age, std::string skill,
                           int episode_length, int version = 1);

std::unique_ptr<Task> make_table_task(TableKind kind, const TaskSpec& spec,
                                      const std::string& config_file);

// Defines a family member's <id>_spec() and make_<id>() (declared in registry.h).
#define BIDEX_DEFINE_TABLE_TASK(id, kind, ...)                                  \
  const TaskSpec& id##_spec() {                                                 \
    static const TaskSpec spec = table_family_spec(kind, #id, __VA_ARGS__);     \
    return spec;                                                                \
  }                                                                             \
  std::unique_ptr<Task> make_##id(const std::string& config_file) {             \
    return make_table_task(kind, id##_spec(), config_file);                     \
  }

BIDEX_STAGE_BODIES(Table, TableProgram, table_);

class TableTask : public BodyTask<Task, TableBodies> {
 public:
  TableTask(TableKind kind, const TaskSpec& spec, TableParams params);

  const TableParams& params() const { return p_; }
  TableKind kind() const { return kind_; }
  int episode_length() const override { return p_.episode_length; }
  sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                          const sim::PhysicsOptions& physics) const override;
  void bind(const sim::SimModel& model) override;


 private:
  TableKind kind_;
  TableParams p_;
};

}  // namespace bidex::tasks
