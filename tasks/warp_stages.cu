// The task stages as CUDA kernels over the GPU backend's arrays: one thread per world runs the
// per-world functions of tasks/world_step.h, launched on the backend's stream so that they are
// ordered with its graphs. One kernel set per family in tasks/gpu_families.h.
#include <cuda_runtime.h>

#include <string>

#include "core/error.h"
#include "tasks/gpu_families.h"
#include "tasks/warp_env.h"

namespace bidex::tasks {

namespace {

constexpr int kBlock = 128;

template <class B, Stage S>
__global__ void stage_kernel(const typename B::Program* p, WorldArrays a, int n) {
  const int w = blockIdx.x * blockDim.x + threadIdx.x;
  if (w < n) world_stage<B, S>(*p, a, w);
}

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw DeviceError(std::string("task stages: ") + what + ": " + cudaGetErrorString(e));
}

template <class B>
class CudaRunner : public StageRunner {
 public:
  CudaRunner(const typename B::Program& p, uintptr_t stream)
      : stream_(reinterpret_cast<cudaStream_t>(stream)) {
    check(cudaMalloc(&p_, sizeof(p)), "allocating the task's program");
    check(cudaMemcpyAsync(p_, &p, sizeof(p), cudaMemcpyHostToDevice, stream_), "copying it");
    check(cudaStreamSynchronize(stream_), "copying it");
  }
  ~CudaRunner() override { cudaFree(p_); }
  void run(Stage s, const WorldArrays& a, int n) override {
    with_stage(s, [&](auto stage) {
      stage_kernel<B, decltype(stage)::value><<<grid(n), kBlock, 0, stream_>>>(p_, a, n);
    });
    check(cudaGetLastError(), stage_name(s));
  }

 private:
  static int grid(int n) { return (n + kBlock - 1) / kBlock; }
  typename B::Program* p_ = nullptr;
  cudaStream_t stream_;
};

}  // namespace

std::unique_ptr<StageRunner> make_cuda_runner(const Task& task, uintptr_t stream) {
#define BIDEX_X(name, Task_)     \
  if (auto* t = dynamic_cast<const Task_*>(&task)) \
    return std::make_unique<CudaRunner<Task_::Bodies>>(t->program(), stream);
  BIDEX_GPU_FAMILIES(BIDEX_X)
#undef BIDEX_X
  return nullptr;
}

}  // namespace bidex::tasks
