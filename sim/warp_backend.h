// WarpBackend: the worlds of one SimModel, or of several scenes of one topology, on MuJoCo Warp
// (GPU.md's design, sim/README.md).
//
// Python runs at construction only: it loads the same compiled model (a binary copy of SimModel's
// mjModel), puts it on the device, allocates the worlds and captures three passes as CUDA
// graphs (sim/warp_bridge.py): the control step (substeps with the base forces at the pivots,
// then the fault check), and the two halves of a reset (marked worlds back to the initial state;
// then the position pass after task code wrote their rows). C++ launches the graphs on the
// backend's stream through the CUDA driver; every array is world-major float32 memory on the
// device whose pointer C++ holds. On Warp's CPU device (tests without a GPU) the same passes run
// as Python calls and the pointers are host memory.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "sim/model.h"
#include "sim/state_view.h"

namespace bidex::sim {

struct WarpOptions {
  std::string device = "cuda";  // a Warp device: "cuda", "cuda:1", or "cpu" (tests)
  // room per world: constraint rows and contacts (0: the scene's PhysicsOptions gpu.njmax and
  // gpu.nconmax); a world that needs more is flagged (kFaultOverflow), reset and counted
  int njmax = 0;
  int nconmax = 0;
  // Sensors at every substep, as MuJoCo Warp's own step computes them. By default the substeps
  // before the last skip them (no sensor keeps a history in bidex's scenes): the state and the
  // sensor values at the end of a control step are the same either way.
  bool sensors_every_substep = false;
};

// The kinds of room a world can run out of (bits of the overflow_seen array; sim/warp_bridge.py
// maps MuJoCo Warp's overflow word onto them), each widened by one physics setting.
enum OverflowKind : uint32_t {
  kOverflowRows = 1u << 0,      // constraint rows: gpu.njmax
  kOverflowContacts = 1u << 1,  // contacts and collision pairs: gpu.nconmax
  kOverflowOther = 1u << 2,     // another of MuJoCo Warp's buffers
};

// One world-major array: `rows` worlds of `width` values (float32, or the named integer type).
struct WorldArray {
  uintptr_t ptr = 0;  // device address (host address on Warp's CPU device)
  int rows = 0;
  int width = 0;
  size_t row_bytes = 0;  // bytes from one row to the next
};

// Whether this build can make a WarpBackend, and if not why (names what to install).
bool warp_built();
std::string warp_missing();
// Throws the DeviceError of `--device cuda` where this build has no GPU backend or the machine
// no NVIDIA driver, naming what is missing; returns otherwise.
void require_gpu();

class WarpBackend {
 public:
  // Throws DeviceError naming what is missing (this build's Python embedding, the mujoco,
  // warp-lang or mujoco-warp packages, a GPU) and how to install it.
  WarpBackend(const SimModel& model, int nworld, WarpOptions options = {});
  // Several scenes of one topology (topology_groups) stepped as one MuJoCo Warp Model: scene
  // k's worlds[k] worlds follow scene k-1's, and the fields in which the scenes differ (body
  // poses, joint axes, initial positions, ...) hold per-world values. The scenes' physics
  // settings must agree (substeps, speed limit, hand bases); each world's room is the largest
  // of theirs. Throws Error naming what differs.
  WarpBackend(const std::vector<const SimModel*>& scenes, const std::vector<int>& worlds,
              WarpOptions options = {});
  // Groups scenes that one backend can step: each scene's group, numbered by first appearance
  // (sim/warp_bridge.py, topology_groups). Throws DeviceError as the constructor does.
  static std::vector<int> topology_groups(const std::vector<const SimModel*>& scenes);
  ~WarpBackend();
  WarpBackend(const WarpBackend&) = delete;
  WarpBackend& operator=(const WarpBackend&) = delete;

  const SimModel& model() const { return *model_; }  // the first scene
  int nworld() const { return nworld_; }
  const std::vector<int>& scene_worlds() const { return scene_worlds_; }
  bool on_gpu() const;
  const WarpOptions& options() const { return options_; }

  // Named world-major arrays: qpos, qvel, ctrl, qfrc_actuator, qfrc_constraint, sensordata, xpos,
  // xquat, cvel, subtree_com, mocap_pos, mocap_quat, xfrc_applied, time (float32); base_wrench
  // (float32, 6 per free base); fault (uint32 FaultBits of the last step), fault_seen (uint32:
  // every FaultBit the world has met), fault_count and overflow_count (int64 per world),
  // overflow_seen (uint32: every OverflowKind the world has met), rows_max (int32: the most
  // constraint rows the world has needed at the end of a step), efc_rows and solver_iters (int64
  // per world: its constraint rows and its solver's iterations at the end of each control step,
  // summed, as SimBatch sums them), reset (int32: 1 marks a world for the next reset).
  WorldArray array(const std::string& name) const;
  // Rows [first, first + count) of a named array (one scene's worlds); throws Error outside it.
  WorldArray rows(const std::string& name, int first, int count) const;

  // One control step of every world, then the fault check, which marks faulty worlds in `reset`.
  // Asynchronous on a GPU: it returns once the work is queued on the backend's stream.
  void step();
  // Worlds marked in `reset` back to the scene's initial state: targets at the joints, no base
  // forces, zero velocity. Task code then writes their reset rows; reset_end runs the position
  // pass (poses, centres of mass, velocities) so that observations see the new state.
  void reset_begin();
  void reset_end();
  // Benchmarks: uniform targets over the control ranges and base forces/torques up to the caps.
  void random_inputs(uint64_t seed, int64_t step, double max_force, double max_torque);
  // Benchmarks: uniform float32 values in [lo, hi) into an allocated array (random actions).
  void random_fill(const std::string& name, uint64_t seed, int64_t step, float lo, float hi);
  // Benchmarks: the substeps of raw MuJoCo Warp, without bidex's passes.
  void raw_step();
  // Waits for the queued work.
  void synchronize();

  // A zeroed world-major array of `width` values of `elem_bytes` each, owned by the backend and
  // named like its own arrays (task state and outputs live beside the physics); `rows` rows
  // (0: one per world; a pack's rows span the worlds of all its scenes).
  WorldArray allocate(const std::string& name, int width, size_t elem_bytes, int rows = 0);
  // The CUDA stream the graphs run on (a CUstream; 0 on Warp's CPU device): kernels launched on
  // it are ordered with the passes.
  uintptr_t stream() const;

  // Copies between an array and host memory (tests, summaries; waits for the stream), the
  // bytes ones from row `first_row` on; a copy past the array's end is an Error.
  std::vector<float> download(const std::string& name) const;
  template <class T>
  std::vector<T> download_as(const std::string& name) const;
  void upload(const std::string& name, const std::vector<float>& values);
  void upload_bytes(const std::string& name, const void* src, size_t bytes, int first_row = 0);
  void download_bytes(const std::string& name, void* dst, size_t bytes, int first_row = 0) const;

  // Faults and overflows over all worlds since construction (copies two arrays to the host).
  int64_t total_faults() const;
  int64_t total_overflows() const;
  // Per fault kind (sim::fault_kind_name) met since construction, the worlds that met it
  // (copies one array); kinds no world met are left out.
  std::map<std::string, int64_t> fault_kinds() const;
  // Benchmarks: milliseconds per call of raw stepping's parts (collision, make_constraint,
  // forward_before_solve, forward, step), each replayed on the state `steps` control steps of the
  // current inputs reach (sim/warp_bridge.py, Bridge.phase_profile).
  std::map<std::string, double> phase_profile(int steps);
  // The most constraint rows any world has needed since construction (copies one array): the
  // use of the room `options().njmax`.
  int max_rows() const;
  // Empty when no world overflowed its room; else a line saying how many overflows there were,
  // of which kinds (OverflowKind), and which physics settings to raise (gpu.njmax for constraint
  // rows, gpu.nconmax for contacts).
  std::string room_advice() const;
  // Bytes Warp holds on the device (0 on the CPU device).
  size_t device_bytes() const;

 private:
  struct Impl;
  const SimModel* model_;
  int nworld_ = 0;
  std::vector<int> scene_worlds_;
  WarpOptions options_;
  std::unique_ptr<Impl> impl_;
};

template <class T>
std::vector<T> WarpBackend::download_as(const std::string& name) const {
  const WorldArray a = array(name);
  std::vector<T> out(static_cast<size_t>(a.rows) * a.width);
  download_bytes(name, out.data(), out.size() * sizeof(T));
  return out;
}

}  // namespace bidex::sim
