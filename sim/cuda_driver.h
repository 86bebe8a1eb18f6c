// The few CUDA driver calls the GPU backend makes per step (graph launch, copies, waits), loaded
// at run time from the NVIDIA driver (libcuda.so.1), so building bidex needs no CUDA toolkit and
// a machine without a GPU can still load it. Every call names what failed in a RuntimeError.
#pragma once

#include <cstddef>
#include <cstdint>

namespace bidex::sim::cuda {

// True when the driver library loads (does not mean a GPU is present).
bool driver_available();

// Handles as the driver sees them (CUcontext, CUstream, CUgraphExec, CUdeviceptr).
struct Stream {
  uintptr_t context = 0;
  uintptr_t stream = 0;
};

void launch_graph(const Stream& s, uintptr_t graph_exec);
void synchronize(const Stream& s);
// Copies on the stream, then waits for it.
void copy_to_host(const Stream& s, void* dst, uintptr_t src, size_t bytes);
void copy_to_device(const Stream& s, uintptr_t dst, const void* src, size_t bytes);

}  // namespace bidex::sim::cuda
