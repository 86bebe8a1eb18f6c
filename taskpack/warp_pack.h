// WarpPack: a pack on the GPU backend. Each entry's task runs as a WarpTaskEnv. Entries whose
// scenes share one topology share one backend (one MuJoCo Warp Model with per-world values, one
// Data; WarpPackOptions::share_scenes); every other entry has its own. Each backend steps on its
// own CUDA stream, so the backends of a multi-task pack step concurrently; after its step each
// entry's rows are written into the pack's padded rows by a kernel on its backend's stream
// (taskpack/pack_row.h, the same function the CPU pack calls). The
// pack's outputs stay in device memory, where a learner reads them in place (rl/collector.h).
// The layout, seeds and episode statistics are the CPU pack's (taskpack/pack.h); on Warp's CPU
// device (tests without a GPU) the same code runs with host memory.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "taskpack/pack.h"
#include "taskpack/pack_row.h"
#include "tasks/warp_env.h"

namespace bidex::taskpack {

struct WarpPackOptions {
  uint64_t seed = 0;             // entry g runs with group_seed(seed, g), as on the CPU
  std::string device = "cuda";   // a Warp device: cuda, cuda:N, or cpu (tests)
  std::string hand_file;         // empty: configs/hands/shadow.yaml
  std::string physics_file;      // empty: configs/sim/physics.yaml
  // Entries whose scenes share one topology (the catch tasks, the door tasks) step as one
  // MuJoCo Warp Model with per-world values (tasks::WarpTaskEnv::make_envs): fewer, larger
  // launches, the same rows. false: each entry on its own backend.
  bool share_scenes = true;
};

class WarpPack : public Pack {
 public:
  // Throws what WarpTaskEnv throws (no GPU, packages missing, a family without GPU stages), and
  // the layout's ConfigErrors before any scene is built.
  WarpPack(const PackSpec& spec, const WarpPackOptions& options);
  ~WarpPack() override;

  std::string device() const override { return options_.device; }
  int threads() const override { return 1; }
  bool on_gpu() const;
  tasks::WarpTaskEnv& group(int g) { return *envs_[g]; }
  const tasks::WarpTaskEnv& group(int g) const { return *envs_[g]; }

  // Starts a new episode in every slot and writes the rows. Returns when they are written.
  void reset() override;
  // One control step of every slot with the rows in actions(), which the caller has written
  // (and whose writes have finished) before the call. Returns when every output is written.
  void step();
  // Host actions (nslot x act_dim) copied in, then step() (tests, benchmarks).
  void step(const std::vector<float>& actions);
  // Autoreset of every entry (tasks::WarpTaskEnv::set_autoreset) and new episodes in the slots
  // whose `mask` value (nslot values) is nonzero, their rows rewritten (TaskPack's, on the GPU).
  void set_autoreset(bool on);
  bool autoreset() const { return envs_[0]->autoreset(); }
  void reset_slots(const uint8_t* mask);

  // The pack's device rows, float32, one row per pack slot: actions (nslot x act_dim, written
  // by the caller), obs and final_obs (nslot x obs_dim; final_obs is valid where done is 1),
  // reward (scaled), done and bootstrap (1 where the time limit cut the episode and the world
  // did not fault: its final_obs is worth a value estimate).
  float* actions() const { return ptr(actions_); }
  float* obs() const { return ptr(obs_); }
  float* final_obs() const { return ptr(final_obs_); }
  float* reward() const { return ptr(reward_); }
  float* done() const { return ptr(done_); }
  float* bootstrap() const { return ptr(bootstrap_); }
  // A copy of a device row array on the host (tests, summaries): obs, final_obs, reward, done,
  // bootstrap or actions.
  std::vector<float> download(const std::string& name) const;

  std::vector<tasks::EpisodeStats> take_stats() override;
  bool curriculum(int g) const override { return envs_.at(g)->task().curriculum(); }
  void set_levels(int g, double level) override { envs_.at(g)->set_levels(level); }
  // Faults and overflows over all entries' worlds since construction, and what to raise.
  int64_t total_faults() const;
  std::string room_advice() const;
  // Per entry, the most constraint rows any of its worlds has needed since construction, and
  // its room (the scene's gpu.njmax): how close training comes to an overflow.
  struct Rows {
    int needed = 0, room = 0;
  };
  std::vector<Rows> rows() const;
  // Host seconds spent queueing the entries' steps (kernels and graphs) since construction: a
  // pack whose launches take as long as its step is bound by the host, not the GPU.
  double launch_seconds() const { return launch_seconds_; }
  void set_profile(bool on) override;
  // Summed over entries: wall, actions (apply kernels) and task seconds; physics is the rest.
  tasks::StageProfile profile() const override;
  void set_goal_shifts(int g, const std::vector<int>& local,
                       const std::vector<double>& shifts) override {
    envs_.at(g)->set_goal_shifts(local, shifts);
  }

 private:
  static float* ptr(uintptr_t p) { return reinterpret_cast<float*>(p); }
  void write_rows();  // every entry's rows, each on its entry's stream, then waits
  void write_reset_rows();  // the same after a reset: no reward, no episode ended
  void reset_backend(size_t k, const uint8_t* mask);  // backend k's entries, mask or all
  void synchronize_backends();
  LoadSums load_sums() const override;  // copies two arrays of each backend

  WarpPackOptions options_;
  std::vector<std::unique_ptr<tasks::WarpTaskEnv>> envs_;
  std::vector<std::vector<int>> backends_;  // per backend, its entries in world order
  std::vector<EntryRows> rows_;
  uintptr_t actions_ = 0, obs_ = 0, final_obs_ = 0, reward_ = 0, done_ = 0, bootstrap_ = 0;
  double launch_seconds_ = 0;
  int64_t steps_ = 0;  // control steps since construction
};

// The device a pack of `spec` steps on: "cpu" or "cuda" as asked, or for "auto" cuda when this
// build has the GPU backend, the NVIDIA driver loads and every entry's task runs there (see
// tasks::choose_device), else cpu. `why` gets a short reason. Another value is a ConfigError.
std::string choose_pack_device(const std::string& requested, const PackSpec& spec,
                               std::string* why = nullptr);

// The CUDA kernel of one entry's rows on `stream` (warp_rows.cu); false in a build without CUDA.
bool launch_entry_rows(const EntryRows& rows, uintptr_t stream);

}  // namespace bidex::taskpack
