// The GPU engine on a CUDA device (built only when CMake found a CUDA compiler; this header
// has no CUDA types, so plain C++ code can use it).
//
// Kernels run the stage functions of smooth.h / constraint.h / step.h with a group of `lanes`
// threads of one warp per world (4, 8, 16 or 32): the per-body, per-dof and per-row loops of a
// stage are spread over the group, tree passes go level by level with a warp barrier between
// levels. step() is one fused kernel that runs every stage of every substep of a world without
// leaving the kernel; forward() launches one kernel per stage (the parity check compares each
// stage's output; the benchmark times them one by one).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "sim/gpu/engine.h"
#include "sim/gpu/model.h"

namespace bidex::sim::gpu {

// Number of CUDA devices (0 when there is no driver or no device).
int cuda_device_count();
// "NVIDIA H100 80GB HBM3, 132 SMs, 79.1 GiB, compute 9.0" (or why there is none).
std::string cuda_device_description();

class DeviceEngine : public Engine {
 public:
  // The world group width (threads per world).
  virtual int lanes() const = 0;
  // Caps the grid at `n` blocks of 128 threads per SM (0: no cap, one lane group per world);
  // with a cap each group walks several worlds in turn, so fewer worlds' data compete for the
  // caches at a time.
  virtual void set_resident_blocks_per_sm(int n) = 0;
  virtual int resident_blocks_per_sm() const = 0;
  // Bytes of device memory held for the worlds' fields and for the model.
  virtual size_t state_bytes() const = 0;
  virtual size_t model_bytes() const = 0;
  // Puts every world at the model's reference pose at rest, with the applied forces `xfrc`
  // (nbody x 6, e.g. gravity compensation; empty: none) and random controls (on the device, no
  // host copy of the worlds).
  virtual void reset_worlds(const std::vector<double>& xfrc, uint64_t seed) = 0;
  // Runs `launches` control steps: new uniform random controls in the control ranges (one small
  // kernel), then one fused launch of `substeps` physics steps, with `observe` followed by a
  // position and velocity pass so that poses and velocities describe the state after the last
  // step. Returns seconds (CUDA events around all launches).
  virtual double time_steps(int launches, int substeps, bool observe, uint64_t seed) = 0;
  // Seconds of one launch of each stage kernel over all worlds (averaged over `repeats`), in
  // pipeline order, after a forward pass that gives every stage its inputs.
  virtual std::vector<std::pair<std::string, double>> time_stages(int repeats) = 0;
  // Worlds whose fault word is nonzero (read back from the device).
  virtual int faulty_worlds() = 0;
  // Mean over the worlds of the solver iterations of their last physics step.
  virtual double mean_solver_iterations() = 0;
};

// A device engine for `nworld` worlds in float32 or float64 with `lanes` threads per world.
// Throws std::runtime_error when CUDA fails (no device, out of memory).
std::unique_ptr<DeviceEngine> make_device_engine(const ModelArrays& arrays, int nworld,
                                                 bool float32, int lanes);

}  // namespace bidex::sim::gpu
