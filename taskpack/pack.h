// TaskPack: any mix of tasks in one batched instance. Each entry of a pack spec (task id, slot
// count, task YAML with its goal parameters, reward scale) becomes a group of consecutive slots;
// one call to step() runs every slot of every group inside one parallel loop over all slots
// (taskpack/README.md). Observations and actions are padded to one width for the whole pack:
//   observation row = [the task's own observation | zeros up to obs_pad | one-hot entry id]
//   (multi-task mode), or the task's observation with its goal slices zeroed (meta mode);
//   action row = [the task's actions | ignored entries up to act_pad].
// Rewards are the task's reward times the entry's reward scale; episode statistics are kept per
// entry, unscaled. Same seed and actions => bitwise identical results for any thread count.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <array>
#include <string>
#include <vector>

#include "tasks/env.h"

namespace bidex::taskpack {

enum class PackMode {
  kPlain,      // the task's observation, padded
  kMultiTask,  // + one-hot entry id (MT suites)
  kMeta,       // goal slices zeroed, no id (ML suites)
};
const char* mode_name(PackMode m);  // "plain", "multitask", "meta"

struct PackEntry {
  std::string task;           // a task or variant id (tasks::find_task)
  std::string label;          // the entry's name in metrics and reports (empty: task)
  std::string config;         // the task's YAML, goal parameters included (empty: its default)
  int slots = 1;
  double reward_scale = 1.0;
  // Goal shifts (m) of a goal distribution (suite.h): the entry's slots take them in turn, slot
  // i goals[i % size] (every goal of a two-goal task moves by it); empty: the configured goal.
  std::vector<std::array<double, 3>> goals;
};

struct PackSpec {
  std::string name;             // e.g. "MT4", or a task id for a one-task pack
  PackMode mode = PackMode::kPlain;
  std::vector<PackEntry> entries;
  int obs_pad = 0;   // padded task-observation width (0: the widest entry's); >= every entry's
  int act_pad = 0;   // padded action width (0: the widest entry's)
  int one_hot = 0;   // one-hot width in multi-task mode (0: the number of entries)
};

struct PackOptions {
  int threads = 0;            // 0: all cores
  uint64_t seed = 0;          // entry g runs with group_seed(seed, g)
  std::string hand_file;      // empty: configs/hands/shadow.yaml
  std::string physics_file;   // empty: configs/sim/physics.yaml
};

// The seed of entry g's slots: seed + g * 0x9E3779B97F4A7C15 (mod 2^64). Entry 0 runs with the
// pack's seed, so a one-entry pack is the task alone with the same seed.
uint64_t group_seed(uint64_t seed, int g);

// What every pack of a spec shares, on either device: the entries checked, labelled and laid
// out as consecutive slot groups, the padded widths and the observation masks. A pack spec with
// an invalid entry (unknown task, slots < 1, reward scale not finite, a pad narrower than an
// entry) is a ConfigError naming the entry, raised before any scene is built.
class Pack {
 public:
  virtual ~Pack();
  Pack(const Pack&) = delete;
  Pack& operator=(const Pack&) = delete;

  const PackSpec& spec() const { return spec_; }
  int nslot() const { return nslot_; }
  int obs_dim() const { return obs_dim_; }   // obs_pad + one-hot width
  int act_dim() const { return act_dim_; }   // act_pad
  int obs_pad() const { return obs_pad_; }
  int ngroups() const { return static_cast<int>(specs_.size()); }
  const PackEntry& entry(int g) const { return spec_.entries[g]; }
  const std::string& label(int g) const { return spec_.entries[g].label; }  // never empty
  const tasks::TaskSpec& task_spec(int g) const { return *specs_[g]; }
  int group_begin(int g) const { return begin_[g]; }   // first pack slot of entry g
  int group_slots(int g) const { return spec_.entries[g].slots; }
  int group_of(int slot) const;                        // entry of a pack slot
  int one_hot_offset() const;                          // -1 unless multi-task mode
  // Per entry, obs_pad values: 1 where the pack passes the task's observation through, 0 where
  // it writes zeros (padding, and goal slices in meta mode).
  const std::vector<uint8_t>& obs_keep(int g) const { return keep_[g]; }
  // The one-hot column of entry g's rows (-1: none).
  int hot_column(int g) const { return spec_.mode == PackMode::kMultiTask ? obs_pad_ + g : -1; }

  // Where the pack steps: "cpu" (TaskPack), or the GPU backend's device (WarpPack).
  virtual std::string device() const = 0;
  // Simulation threads on the host (the GPU pack: 1, its host only queues work).
  virtual int threads() const = 0;
  // Starts a new episode in every slot.
  virtual void reset() = 0;
  // Episodes finished since the last call, per entry (unscaled returns).
  virtual std::vector<tasks::EpisodeStats> take_stats() = 0;
  // Whether entry g's task trains under a curriculum (tasks::Task::curriculum), and its slots'
  // levels set (tasks::set_levels), from each slot's next reset.
  virtual bool curriculum(int g) const = 0;
  virtual void set_levels(int g, double level) = 0;
  // Timing of the steps since set_profile(true): see each pack for what the fields hold.
  virtual void set_profile(bool on) = 0;
  virtual tasks::StageProfile profile() const = 0;
  // Goal shifts of slots of entry g (tasks::set_goal_shifts: `local` counts from the entry's
  // first slot), from each slot's next reset; meta-RL samples goals per slot with it.
  virtual void set_goal_shifts(int g, const std::vector<int>& local,
                               const std::vector<double>& shifts) = 0;

  // The physics' load per slot and control step since the last call (the first: since the pack
  // was built): the mean constraint rows at a step's end and the mean solver iterations of its
  // last substep, on either device (sim::SimBatch::efc_rows); NaN without a step since. A
  // simulation that slows as training goes on shows here whether its contacts grew.
  struct PhysicsLoad {
    double rows = std::numeric_limits<double>::quiet_NaN();
    double iterations = std::numeric_limits<double>::quiet_NaN();
  };
  PhysicsLoad take_load();

  // Gives every entry with goals its slots' shifts in turn (PackEntry::goals), from their next
  // reset; the packs call it once they are built.
  void assign_goals();
  // Meta-RL's task of each slot: an entry is one task, or with goals (PackEntry::goals) one
  // task per goal, slot i of the entry having goal i % goals; tasks are numbered entry by entry.
  // `ntasks` (if given) receives their count.
  std::vector<int> slot_tasks(int* ntasks = nullptr) const;

 protected:
  explicit Pack(const PackSpec& spec);
  // Sums since construction over every slot's control steps: constraint rows, solver
  // iterations and the slot-steps they cover.
  struct LoadSums {
    int64_t rows = 0, iterations = 0, slot_steps = 0;
  };
  virtual LoadSums load_sums() const = 0;
  PackSpec spec_;
  std::vector<const tasks::TaskSpec*> specs_;
  std::vector<int> begin_;
  std::vector<std::vector<uint8_t>> keep_;
  std::vector<int> slot_group_;  // entry of each pack slot
  int nslot_ = 0, obs_dim_ = 0, act_dim_ = 0, obs_pad_ = 0, one_hot_ = 0;

 private:
  LoadSums load_taken_;  // load_sums() at the last take_load
};

// The pack on the CPU: one TaskEnv per entry, every slot of every entry stepped in one parallel
// loop, outputs in host vectors.
class TaskPack : public Pack {
 public:
  TaskPack(const PackSpec& spec, const PackOptions& options);
  ~TaskPack() override;

  std::string device() const override { return "cpu"; }
  int threads() const override;
  tasks::TaskEnv& group(int g) { return *envs_[g]; }
  const tasks::TaskEnv& group(int g) const { return *envs_[g]; }

  // Starts a new episode in every slot and writes `obs`.
  void reset() override;
  // Autoreset of every entry (tasks::TaskEnv::set_autoreset): off, a slot whose episode ends
  // keeps its final observation in `obs` and is held until reset_slots.
  void set_autoreset(bool on);
  bool autoreset() const { return envs_[0]->autoreset(); }
  // New episodes in the slots whose `mask` value (nslot values) is nonzero; their rows are
  // written, the other slots' rows are untouched.
  void reset_slots(const uint8_t* mask);
  // One control step of every slot; `actions` holds nslot x act_dim values (entries past the
  // task's own action width are ignored).
  void step(const float* actions);
  void step(const std::vector<float>& actions);

  // Results of the last step, rows per pack slot (widths obs_dim, 1, ...), as in TaskEnv.
  std::vector<float> obs, final_obs, reward;   // reward: the task's reward x reward_scale
  std::vector<uint8_t> terminated, truncated, success, fault;

  std::vector<tasks::EpisodeStats> take_stats() override;
  bool curriculum(int g) const override { return envs_.at(g)->task().curriculum(); }
  void set_levels(int g, double level) override { envs_.at(g)->set_levels(level); }
  void set_profile(bool on) override;
  // wall: the pack's steps; actions and task: thread-seconds summed over entries
  tasks::StageProfile profile() const override;
  void set_goal_shifts(int g, const std::vector<int>& local,
                       const std::vector<double>& shifts) override {
    envs_.at(g)->set_goal_shifts(local, shifts);
  }

 private:
  void write_row(int g, int local, int slot);  // pack rows of one slot from its entry's env

  LoadSums load_sums() const override;

  std::vector<std::unique_ptr<tasks::TaskEnv>> envs_;
  int64_t steps_ = 0;  // control steps since construction
  bool profile_on_ = false;
  tasks::StageProfile wall_;     // steps and wall time of the pack's steps
};

}  // namespace bidex::taskpack
