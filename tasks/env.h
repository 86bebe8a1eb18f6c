// TaskEnv: one task on N slots. Owns the compiled scene, the simulation batch, the per-slot task
// state and the float32 buffers that learning code reads. One call to step() runs, per slot and
// inside one parallel loop over slots (tasks/README.md; step_slot is one slot's part):
//   1. apply_actions  2. physics (substeps)  3. evaluate: reward terms, termination, success
//   4. reset of finished slots  5. observe
// Same seed and actions => bitwise identical results for any thread count.
#pragma once

#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "sim/batch.h"
#include "tasks/task.h"

namespace bidex::tasks {

struct EnvOptions {
  int nslot = 1;
  int threads = 0;            // 0: all cores
  uint64_t seed = 0;
  std::string hand_file;      // empty: configs/hands/shadow.yaml
  std::string physics_file;   // empty: configs/sim/physics.yaml
};

// Episodes finished since the last take_stats().
struct EpisodeStats {
  int64_t episodes = 0;
  int64_t successes = 0;
  int64_t terminated = 0;     // ended by the task (drop, drift, ...)
  int64_t truncated = 0;      // ended by the time limit or a fault
  int64_t faults = 0;         // slots reset by a fault (non-finite or exploded simulation,
                              // a non-finite reward or observation, ...)
  double return_sum = 0;
  double length_sum = 0;
  std::vector<double> term_sums;  // per reward term: sum over episodes of the term's return
  // A task with a curriculum (Task::curriculum): the sum of the slots' levels when the stats
  // were taken, over the `levels` slots whose level has started (TaskParams::level_started)
  double level_sum = 0;
  int64_t levels = 0;
};

// Adds the started levels of `n` slot states to `st` (EpisodeStats::level_sum, levels).
void add_levels(EpisodeStats& st, const SlotState* states, int n);

// Every slot's curriculum level set to `level` (started), from its next reset (a resumed run's
// levels, rl's trainer). Throws Error naming the task when it has no curriculum or the level is
// not in [0, 1]; then no state has changed.
void set_levels(const Task& task, SlotState* states, int nslot, double level);

// Wall time of the stages, summed over steps since set_profile(true).
struct StageProfile {
  int64_t steps = 0;
  double wall = 0;     // seconds of step() in total
  double actions = 0;  // thread-seconds in apply_actions
  double task = 0;     // thread-seconds in evaluate + reset + observe
};

// The task's scene (hands from `hand_file`, physics from `physics_file`; empty: the defaults),
// compiled, and the task bound to it. `on_gpu`: with the GPU backend's physics step
// (PhysicsOptions::on_gpu).
std::unique_ptr<sim::SimModel> build_task_model(Task& task, const std::string& hand_file,
                                                const std::string& physics_file,
                                                bool on_gpu = false);

// Per-slot goal shifts (TaskParams::goal_shift) into `states` of `nslot` slots: `shifts` holds,
// for each slot listed in `slots`, spec.goal_shifts x 3 values (m). They apply from each slot's
// next reset and stay until set again. Throws Error naming the task, the slot or the sizes when
// the task takes no per-slot goals, a slot is out of range, the sizes disagree or a value is not
// finite; then no state has changed.
void set_goal_shifts(const TaskSpec& spec, SlotState* states, int nslot,
                     const std::vector<int>& slots, const std::vector<double>& shifts);

// A random policy's actions: every value uniform in [-1, 1], drawn in order from `rng`.
void random_actions(std::vector<float>& actions, std::mt19937_64& rng);

class TaskEnv {
 public:
  TaskEnv(std::unique_ptr<Task> task, const EnvOptions& options);
  ~TaskEnv();
  TaskEnv(const TaskEnv&) = delete;
  TaskEnv& operator=(const TaskEnv&) = delete;

  const TaskSpec& spec() const { return task_->spec(); }
  const Task& task() const { return *task_; }
  const sim::SimModel& model() const { return *model_; }
  sim::SimBatch& batch() { return *batch_; }
  const sim::SimBatch& batch() const { return *batch_; }
  const SlotState& slot_state(int s) const { return state_[s]; }
  // A slot as the task's stage functions see it (tests craft states through it: edit
  // slot.data / slot.task, then sim::sync_slot).
  TaskSlot slot(int s);
  int nslot() const { return nslot_; }
  int obs_dim() const { return obs_dim_; }
  int act_dim() const { return act_dim_; }
  int nterms() const { return nterms_; }
  int threads() const { return batch_->threads(); }

  // Starts a new episode in every slot and writes `obs`.
  void reset();
  // Autoreset, on by default: a slot whose episode ends starts its next episode within that
  // step (`obs` is the new episode's, `final_obs` the last). Off, the slot stays ended: `obs`
  // holds its final observation, and later steps hold it (no physics, reward 0, no flags)
  // until reset_slots starts its next episode (Gymnasium's NEXT_STEP and DISABLED autoreset
  // modes, python/README.md). Turning it on again resumes nothing: ended slots wait for
  // reset_slots or reset.
  void set_autoreset(bool on) { autoreset_ = on; }
  bool autoreset() const { return autoreset_; }
  bool ended(int s) const { return ended_[s] != 0; }
  // New episodes in the slots whose `mask` value (nslot values) is nonzero, the other slots
  // untouched: writes their `obs` and zeroes their reward, terms and flags.
  void reset_slots(const uint8_t* mask);
  // One control step of every slot; `actions` holds nslot x act_dim values (clipped to [-1, 1]
  // here; a NaN reaches the simulation, which flags and resets that slot).
  void step(const float* actions);
  void step(const std::vector<float>& actions);

  // step() in three parts, for callers that run their own parallel loop over the slots of
  // several envs (taskpack::TaskPack): begin_step, then step_slot(s) once for every slot (any
  // order, any threads, concurrently), then end_step. step() is exactly
  // begin_step(actions); parallel for s: step_slot(s); end_step().
  // `stride`: floats between the action rows of consecutive slots (0: act_dim); `actions` must
  // stay valid until end_step.
  void begin_step(const float* actions, int stride = 0);
  // Slot s's part of the step: clip and apply its actions, physics (sim::step_slot), evaluate,
  // reset when finished, observe. Runs inside the caller's parallel loop; never throws.
  void step_slot(int s);
  // Episode records of the slots that finished, in slot order; the step's profile.
  void end_step();

  // Results of the last step (rows per slot).
  std::vector<float> obs;          // nslot x obs_dim: after the reset of finished slots, clipped
  std::vector<float> final_obs;    // nslot x obs_dim: for finished slots, before their reset
  std::vector<float> reward;       // nslot
  std::vector<float> terms;        // nslot x nterms: the reward's terms (reward = their sum)
  std::vector<uint8_t> terminated; // the task ended the episode
  std::vector<uint8_t> truncated;  // the time limit (or a fault) ended it
  std::vector<uint8_t> success;    // the episode's success flag as of this step
  std::vector<uint8_t> fault;      // the slot faulted: the simulation reset it (SimBatch::fault),
                                   // or its reward or observation was not finite

  EpisodeStats take_stats();
  void set_profile(bool on);
  StageProfile profile() const;
  // Goal shifts of some slots (tasks::set_goal_shifts above), from their next reset.
  void set_goal_shifts(const std::vector<int>& slots, const std::vector<double>& shifts);
  // Every slot's curriculum level (tasks::set_levels above), from its next reset.
  void set_levels(double level);

  static constexpr float kObsClip = 5.0f;

 private:
  void start_episode(int s);  // task reset after the simulation's reset
  void restart(int s);        // simulation and task reset of slot s, its obs and cleared flags
  void clear_outputs(int s);  // no reward, no terms, no end, no fault (held, or restarted)
  void post_step(int s);

  std::unique_ptr<Task> task_;
  std::unique_ptr<sim::SimModel> model_;
  std::unique_ptr<sim::SimBatch> batch_;
  int nslot_ = 0, obs_dim_ = 0, act_dim_ = 0, nterms_ = 0, episode_length_ = 0;
  std::vector<SlotState> state_;
  bool autoreset_ = true;
  std::vector<uint8_t> ended_;  // per slot: its episode ended and awaits reset_slots
  const float* actions_ = nullptr;
  int action_stride_ = 0;
  double step_t0_ = 0;
  // per-slot episode accumulators and the record of an episode that ended this step
  std::vector<double> ep_return_, ep_terms_, done_return_, done_terms_;
  std::vector<int> done_length_;
  EpisodeStats stats_;
  bool profile_on_ = false;
  StageProfile profile_;
  std::vector<double> thread_times_;  // per thread: actions, task (padded)
};

}  // namespace bidex::tasks
