// The GPU engine's kernels in double (one translation unit per precision).
#include "sim/gpu/device_kernels.cuh"

namespace bidex::sim::gpu::detail {

std::unique_ptr<DeviceEngine> make_cuda_engine_f64(const ModelArrays& a, int nworld, int lanes) {
  return std::make_unique<CudaEngine<double>>(a, nworld, lanes);
}

}  // namespace bidex::sim::gpu::detail
