// The throw-and-catch family (hand_over, catch_underarm, catch_over2underarm, catch_abreast,
// two_catch_underarm): one or two objects thrown from hand to hand, each towards a goal pose.
// The five tasks share this code and differ only in their spec and their YAML (each task's own
// folder holds both, and a README with every decision).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tasks/catch_body.h"
#include "tasks/config_fields.h"
#include "tasks/hands.h"
#include "tasks/objects.h"
#include "tasks/task.h"
#include "tasks/body_task.h"

namespace bidex::tasks {

struct CatchParams {
  std::string file;                 // the YAML it came from
  int episode_length = 75;          // control steps
  ObjectChoice object;              // every object of the task has this shape
  using HandPose = tasks::HandPose;  // roll, pitch, yaw (rad): R = Rz(yaw) Ry(pitch) Rx(roll)
  HandPose right, left;
  struct Throw {
    sim::Vec3 start{};  // object start position
    sim::Vec3 goal{};   // goal position
  };
  std::vector<Throw> objects;       // 1 or 2
  // reset
  double object_position_noise = 0; // +- metres per axis, one sample shared by all objects
  bool random_object_rotation = true;
  bool random_goal_rotation = true;
  double hand_dof_noise = 0;        // fraction of the joint range (see sample_joint_noise)
  // free bases: action +-1 gives force_scale * 1e5 / 60 N and torque_scale * 1e3 / 60 N m
  double force_scale = 0, torque_scale = 0;
  // reward
  double dist_weight = 50;          // alpha in exp(-0.2 (alpha d + theta))
  double success_tolerance = 0.03;  // d (one object) or d1 + d2 (two objects), metres
  double action_penalty = 0;        // coefficient of sum(a^2), added to the reward
  double goal_bonus = 0;            // paid once, on the first step of success
  double fall_penalty = 0;          // added on the step an object falls
  // termination
  double drop_height = 0.1;         // an object's centre at or below this height
  double max_root_drift = 0;        // > 0: a base this far from its anchor ends the episode
  std::vector<sim::Vec3> root_anchors;  // right, left (default: the hands' positions)
  double max_palm_drift = 0;        // > 0: a palm body this far from its anchor ends it
  std::vector<sim::Vec3> palm_anchors;  // right, left
};

// Reads a catch-family YAML strictly (unknown keys, missing fields, wrong types and impossible
// values are ConfigErrors naming file, key, expected and actual value).
CatchParams load_catch_params(const std::string& file, const TaskSpec& spec);

// The spec of a family member: layouts (paper tables), agents and reward terms.
TaskSpec catch_family_spec(std::string id, std::string paper_name, std::string original_name,
                           HumanAge age, Difficulty difficulty, std::string skill,
                           int episode_length, bool free_base, int nobjects);

std::unique_ptr<Task> make_catch_task(const TaskSpec& spec, const std::string& config_file);

// Defines a family member's <id>_spec() and make_<id>() (declared in registry.h); the arguments
// after the id are catch_family_spec's.
#define BIDEX_DEFINE_CATCH_TASK(id, ...)                                          \
  const TaskSpec& id##_spec() {                                                   \
    static const TaskSpec spec = catch_family_spec(#id, __VA_ARGS__);             \
    return spec;                                                                  \
  }                                                                               \
  std::unique_ptr<Task> make_##id(const std::string& config_file) {               \
    return make_catch_task(id##_spec(), config_file);                             \
  }

BIDEX_STAGE_BODIES(Catch, CatchProgram, catch_);

class CatchTask : public BodyTask<Task, CatchBodies> {
 public:
  CatchTask(const TaskSpec& spec, CatchParams params);

  const CatchParams& params() const { return p_; }
  int episode_length() const override { return p_.episode_length; }
  sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                          const sim::PhysicsOptions& physics) const override;
  void bind(const sim::SimModel& model) override;

  // Distance and rotation distance of object i to its goal (the reward's d and theta).
  void goal_error(const TaskSlot& slot, int i, double* d, double* theta) const;

 private:
  CatchParams p_;
};

}  // namespace bidex::tasks
