// Task: the stage functions of one task, called per slot by TaskEnv in the order of the step
// (tasks/README.md): apply_actions -> physics -> evaluate (rewards, termination, success) ->
// reset (finished slots) -> observe. Each works on one slot through a TaskSlot view, so a batch
// of any size (or a pack of different tasks) calls them the same way.
#pragma once

#include <memory>
#include <string>

#include "core/rng.h"
#include "sim/batch.h"
#include "sim/scene.h"
#include "sim/state_view.h"
#include "tasks/slot_state.h"
#include "tasks/spec.h"

namespace bidex::tasks {

// What a task's stage functions see of one slot.
struct TaskSlot {
  int index = 0;
  const sim::SimModel* model = nullptr;
  sim::SlotView state{};          // the slot's rows of the batch arrays (inputs and outputs)
  mjData* data = nullptr;         // MuJoCo data, written by reset only
  SlotRng* rng = nullptr;         // the slot's random stream (rekeyed at every reset)
  SlotState* task = nullptr;
};

// A slot's rows as a stage body sees them (sim/state_view.h): the batch's rows.
sim::WorldRows<double> world_rows(const sim::SlotView& v);
// The slot's rows with its goal markers (the slot's mjData mocap arrays).
sim::WorldRows<double> world_rows(const TaskSlot& t);
// What a reset body writes: the slot's MuJoCo state and goal markers, and the batch's ctrl row
// (the next step's input); end_reset then copies that row into the MuJoCo data's ctrl.
sim::ResetRows<double> reset_rows(TaskSlot& t);
void end_reset(TaskSlot& t);

class Task {
 public:
  explicit Task(const TaskSpec& spec, std::string config_file)
      : spec_(&spec), config_file_(std::move(config_file)) {}
  virtual ~Task() = default;

  const TaskSpec& spec() const { return *spec_; }
  // The YAML file this instance was configured from.
  const std::string& config_file() const { return config_file_; }
  // Episode length in control steps (the config may change the spec's default).
  virtual int episode_length() const { return spec_->episode_length; }
  // Whether the config turns on a training curriculum that moves each slot's
  // TaskParams::level (re_orientation's): EpisodeStats then reports the levels.
  virtual bool curriculum() const { return false; }

  // The scene: hands placed for this task, objects, goal markers, tables.
  virtual sim::SceneBuilder scene(const sim::HandSpec& right_hand,
                                  const sim::PhysicsOptions& physics) const = 0;
  // Looks up what the stage functions need in the compiled scene (called once).
  virtual void bind(const sim::SimModel& model) = 0;

  // Stage functions, per slot. They run inside the parallel loop and must not throw.
  // New episode: the simulation has just been reset to the scene's initial state; randomise the
  // hands, objects and goals from slot.rng, writing slot.data and slot.task.
  virtual void reset(TaskSlot& slot) const = 0;
  // `a` (spec().act.dim() values, already clipped) -> the slot's ctrl and base_wrench rows.
  virtual void apply_actions(const float* a, TaskSlot& slot) const = 0;
  // After physics: writes each reward term (weighted; the reward is their sum) into `terms`,
  // updates slot.task->success, returns whether the episode terminated (failure or end state;
  // time limits are the caller's).
  virtual bool evaluate(TaskSlot& slot, double* terms) const = 0;
  // Writes spec().obs.dim() observation values (unclipped).
  virtual void observe(const TaskSlot& slot, float* obs) const = 0;

 private:
  const TaskSpec* spec_;
  std::string config_file_;
};

}  // namespace bidex::tasks
