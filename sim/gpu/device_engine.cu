// CUDA device queries and the DeviceEngine factory (the kernels are in device_kernels.cuh).
#include "sim/gpu/device_engine.h"

#include <cuda_runtime.h>

#include <cstdio>
#include <string>

namespace bidex::sim::gpu {

namespace detail {
std::unique_ptr<DeviceEngine> make_cuda_engine_f32(const ModelArrays& a, int nworld, int lanes);
std::unique_ptr<DeviceEngine> make_cuda_engine_f64(const ModelArrays& a, int nworld, int lanes);
}  // namespace detail

int cuda_device_count() {
  int n = 0;
  if (cudaGetDeviceCount(&n) != cudaSuccess) {
    cudaGetLastError();  // clear the sticky error of a missing driver
    return 0;
  }
  return n;
}

std::string cuda_device_description() {
  int n = 0;
  cudaError_t e = cudaGetDeviceCount(&n);
  if (e != cudaSuccess) return std::string("no CUDA device: ") + cudaGetErrorString(e);
  if (n == 0) return "no CUDA device";
  int dev = 0;
  cudaGetDevice(&dev);
  cudaDeviceProp p{};
  cudaGetDeviceProperties(&p, dev);
  char gib[32];
  std::snprintf(gib, sizeof gib, "%.1f", p.totalGlobalMem / 1073741824.0);
  return std::string(p.name) + ", " + std::to_string(p.multiProcessorCount) + " SMs, " + gib +
         " GiB, compute " + std::to_string(p.major) + "." + std::to_string(p.minor);
}

std::unique_ptr<DeviceEngine> make_device_engine(const ModelArrays& arrays, int nworld,
                                                 bool float32, int lanes) {
  if (float32) return detail::make_cuda_engine_f32(arrays, nworld, lanes);
  return detail::make_cuda_engine_f64(arrays, nworld, lanes);
}

}  // namespace bidex::sim::gpu
