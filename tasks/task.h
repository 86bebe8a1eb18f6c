// Task: the stage functions of one task, called per slot by TaskEnv in the order of the step
// (tasks/README.md): apply_actions -> physics -> evaluate (rewards, termination, success) ->
// reset (finished slots) -> observe. Each works on one slot through a TaskSlot view, so a batch
// of any size (or a pack of different tasks) calls them the same way.
#pragma once

#include <array>
#include <memory>
#include <random>
#include <string>

#include "sim/batch.h"
#include "sim/scene.h"
#include "tasks/spec.h"

namespace bidex::tasks {

constexpr int kMaxActions = 64;
constexpr int kMaxGoals = 2;
constexpr int kMaxTerms = 16;

// Mutable per-slot task state, beside the simulation state.
struct SlotState {
  int progress = 0;          // control steps since the reset
  bool success = false;      // the success condition held at some step of this episode
  bool bonus_paid = false;   // the one-off goal bonus of this episode was paid
  // goal poses: position (3) then orientation (w, x, y, z)
  std::array<std::array<double, 7>, kMaxGoals> goal{};
  // this step's actions, clipped to [-1, 1] (zeros right after a reset)
  std::array<float, kMaxActions> action{};
};

// What a task's stage functions see of one slot.
struct TaskSlot {
  int index = 0;
  const sim::SimModel* model = nullptr;
  sim::SlotView state{};          // the slot's rows of the batch arrays (inputs and outputs)
  mjData* data = nullptr;         // MuJoCo data, written by reset only
  std::mt19937_64* rng = nullptr; // the slot's random stream (reseeded at every reset)
  SlotState* task = nullptr;
};

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
