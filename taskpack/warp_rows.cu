// The GPU pack's row kernel: one thread per slot of an entry runs pack_slot (pack_row.h), on the
// entry's stream, after its step.
#include <cuda_runtime.h>

#include <string>

#include "core/error.h"
#include "taskpack/warp_pack.h"

namespace bidex::taskpack {

namespace {

constexpr int kBlock = 128;

__global__ void entry_rows_kernel(EntryRows r) {
  const int l = blockIdx.x * blockDim.x + threadIdx.x;
  if (l < r.n) pack_slot(r, l);
}

}  // namespace

bool launch_entry_rows(const EntryRows& r, uintptr_t stream) {
  entry_rows_kernel<<<(r.n + kBlock - 1) / kBlock, kBlock, 0,
                      reinterpret_cast<cudaStream_t>(stream)>>>(r);
  const cudaError_t e = cudaGetLastError();
  if (e != cudaSuccess)
    throw DeviceError(std::string("GPU pack rows: ") + cudaGetErrorString(e));
  return true;
}

}  // namespace bidex::taskpack
