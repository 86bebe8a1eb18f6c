// WarpTaskEnv: one task on N worlds of the GPU backend (sim/warp_backend.h), which it may share
// with tasks of the same scene topology (make_envs). The same step as
// TaskEnv, with every stage on the device: per world (tasks/world_step.h)
//   1. apply_actions  2. physics (the backend's step graph, with its fault check)
//   3. evaluate, time limit, finished-episode records  4. reset of finished worlds (the backend's
//   reset pass, the task's reset body, the position pass)  5. observe
// Outputs stay in device memory (float32 rows, as TaskEnv's); nothing crosses to the host per
// step but the launches. On Warp's CPU device the stages run as a host loop over the same
// arrays (tests). Only families listed in tasks/gpu_families.h run here; others are an error
// that names them.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sim/warp_backend.h"
#include "tasks/env.h"
#include "tasks/task.h"
#include "tasks/world_step.h"

namespace bidex::tasks {

struct WarpEnvOptions {
  int nslot = 1;
  uint64_t seed = 0;
  std::string device = "cuda";  // a Warp device: cuda, cuda:N, or cpu (tests)
  std::string hand_file;        // empty: configs/hands/shadow.yaml
  std::string physics_file;     // empty: configs/sim/physics.yaml
};

// One stage of one family over all worlds (CUDA kernels, or a host loop).
class StageRunner {
 public:
  virtual ~StageRunner() = default;
  virtual void run(Stage s, const WorldArrays& a, int n) = 0;
};

// Whether the task's family has stage bodies on the GPU path (tasks/gpu_families.h).
bool runs_on_warp(const Task& task);

// The device a command runs a task on: "cpu" or "cuda" as asked, or for "auto" cuda when this
// build has the GPU backend, the NVIDIA driver loads and the task's stages run there, else cpu.
// `why` (optional) gets a short reason for the choice. Throws ConfigError for another value.
std::string choose_device(const std::string& requested, const Task& task,
                          std::string* why = nullptr);

class WarpTaskEnv {
 public:
  // Throws DeviceError when the backend cannot start (see WarpBackend), Error when the task's
  // family has no GPU stages yet.
  WarpTaskEnv(std::unique_ptr<Task> task, const WarpEnvOptions& options);
  ~WarpTaskEnv();
  WarpTaskEnv(const WarpTaskEnv&) = delete;
  WarpTaskEnv& operator=(const WarpTaskEnv&) = delete;

  // Envs of several tasks, one per task and in their order, each with its options (the device,
  // hand and physics files must agree). With share_scenes, tasks whose scenes one MuJoCo Warp
  // Model can step (sim::WarpBackend::topology_groups: the catch scenes, the door scenes) form
  // a group on one backend, their worlds one after another: the group launches its physics
  // once per step, on more worlds. Each env still reads and writes only its own worlds, with
  // its own task stages; the group steps together (step). Without share_scenes, or for a task
  // alone in its topology, an env has its own backend, as the constructor gives.
  static std::vector<std::unique_ptr<WarpTaskEnv>> make_envs(
      std::vector<std::unique_ptr<Task>> tasks, const std::vector<WarpEnvOptions>& options,
      bool share_scenes);

  const TaskSpec& spec() const { return task_->spec(); }
  const Task& task() const { return *task_; }
  const sim::SimModel& model() const { return *model_; }  // this task's scene
  // The backend holding this env's worlds, rows [first_world(), first_world() + nslot()) of its
  // arrays; shared with the rest of its group.
  sim::WarpBackend& backend() { return *shared_->backend; }
  const sim::WarpBackend& backend() const { return *shared_->backend; }
  int first_world() const { return first_; }
  // The envs on this env's backend in world order (this env alone unless make_envs shared it).
  const std::vector<WarpTaskEnv*>& group() const { return shared_->members; }
  bool on_gpu() const { return shared_->backend->on_gpu(); }
  int nslot() const { return nslot_; }
  int obs_dim() const { return arrays_.obs_dim; }
  int act_dim() const { return arrays_.act_dim; }
  int nterms() const { return arrays_.nterms; }

  // Starts a new episode in every world and writes `obs`.
  void reset();
  // Autoreset (TaskEnv::set_autoreset): off, a finished world is held at its end (its actions
  // ignored, reward 0, no flags, `obs` its final observation; the physics steps it still, and
  // its next episode resets that) until reset_slots.
  void set_autoreset(bool on) { arrays_.autoreset = on ? 1 : 0; }
  bool autoreset() const { return arrays_.autoreset != 0; }
  // New episodes in the worlds whose `mask` value (nslot values) is nonzero, held or not; their
  // reward, terms and flags are cleared, the other worlds untouched.
  void reset_slots(const std::vector<uint8_t>& mask);
  // One control step of every world of the group (this env's, and its group's other members'),
  // each with the actions in its `actions()` (the caller writes them on the device first: a
  // policy's output, or upload_actions).
  void step();
  // reset_slots of several members of one group at once (one reset pass of their backend):
  // masks[i] has envs[i]->nslot() values. Throws Error for envs of different groups.
  static void reset_worlds(const std::vector<WarpTaskEnv*>& envs,
                           const std::vector<const uint8_t*>& masks);
  // Host actions (nslot x act_dim) copied to the device, then step() (tests, play).
  void step(const std::vector<float>& actions);
  // Reads the actions from `actions` (device memory, `stride` values per world, the first
  // act_dim used) instead of its own array: a pack's padded action rows.
  void set_actions(const float* actions, int stride);
  // Waits for the queued work.
  void synchronize();
  // With the profile on, step() waits after each stage to time it: actions (apply kernel),
  // task (evaluate, reset, observe), wall (the whole step); physics is the rest.
  void set_profile(bool on);
  const StageProfile& profile() const { return profile_; }

  // The env's arrays on the device (world-major): actions, obs, final_obs, reward, terms (float32);
  // terminated, truncated, success, faulted (uint8, one per world); and its rows of the
  // backend's arrays (sim::WarpBackend::array).
  sim::WorldArray array(const std::string& name) const;
  // The most constraint rows any of this env's worlds has needed since construction.
  int max_rows() const;
  template <class T>
  std::vector<T> download(const std::string& name) const;
  // Episodes finished since the last call (copies the per-world records to the host and zeroes
  // them).
  EpisodeStats take_stats();
  // Goal shifts of some worlds (tasks::set_goal_shifts in env.h), from their next reset: the
  // per-world states make one round trip to the host (not per step).
  void set_goal_shifts(const std::vector<int>& slots, const std::vector<double>& shifts);
  // Every world's curriculum level (tasks::set_levels in env.h), the same way.
  void set_levels(double level);

 private:
  std::vector<SlotState> slot_states() const;  // the worlds' task states, copied to the host
  // The worlds' task states copied to the host, changed by edit(SlotState*) and copied back.
  template <class F>
  void edit_slot_states(F&& edit);
  void copy(const std::string& name, void* dst, size_t bytes) const;
  // The scenes' models (before the backend, which points at them), the backend and the envs on
  // it; the last member to go takes them.
  struct Shared {
    std::vector<std::unique_ptr<sim::SimModel>> models;
    std::unique_ptr<sim::WarpBackend> backend;
    std::vector<WarpTaskEnv*> members;
  };
  WarpTaskEnv(std::unique_ptr<Task> task, std::shared_ptr<Shared> shared, int member, int first,
              std::string prefix, const WarpEnvOptions& options);
  // Joins `shared` as scene `member` on worlds [first, first + options.nslot): its arrays, its
  // random streams, its first episodes.
  void join(std::shared_ptr<Shared> shared, int member, int first, const WarpEnvOptions& o);
  bool owns(const std::string& name) const;
  std::string own(const std::string& name) const { return prefix_ + name; }
  std::unique_ptr<Task> task_;
  std::shared_ptr<Shared> shared_;
  const sim::SimModel* model_ = nullptr;
  std::unique_ptr<StageRunner> runner_;
  int nslot_ = 0, first_ = 0;
  std::string prefix_;  // of its own arrays' names on a shared backend
  WorldArrays arrays_{};
  struct Buffer {
    uintptr_t ptr = 0;
    int width = 0;
    size_t elem = 0;
  };
  std::vector<std::pair<std::string, Buffer>> buffers_;
  bool profile_on_ = false;
  StageProfile profile_;
};

template <class T>
std::vector<T> WarpTaskEnv::download(const std::string& name) const {
  const sim::WorldArray a = array(name);
  std::vector<T> out(static_cast<size_t>(a.rows) * a.width);
  copy(name, out.data(), out.size() * sizeof(T));
  return out;
}

// The CUDA runner of a task (warp_stages.cu); nullptr in a build without CUDA.
std::unique_ptr<StageRunner> make_cuda_runner(const Task& task, uintptr_t stream);

}  // namespace bidex::tasks
