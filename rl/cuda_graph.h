// Capturing a learner's step as a CUDA graph, with the fallback every user of it shares: where
// the capture fails, the open capture is ended, a warning names the setting that turns the graph
// off, and the caller runs the step eagerly from then on. CUDA builds only (BIDEX_TORCH_CUDA).
#pragma once

#ifdef BIDEX_TORCH_CUDA
#include <cstdio>
#include <exception>
#include <memory>
#include <string>

#include <ATen/cuda/CUDAGraph.h>
#include <c10/cuda/CUDAStream.h>
#include <cuda_runtime.h>

namespace bidex::rl {

// Records body() (which must read nothing back from the device) into a new graph on `stream`,
// the current stream of the caller's CUDAStreamGuard. Returns the graph, or null where the
// capture failed. `what` names the step in the messages ("PPO's minibatch step"), `key` the
// setting that turns the graph off ("ppo.cuda_graph").
template <class F>
std::unique_ptr<at::cuda::CUDAGraph> capture_cuda_graph(const c10::cuda::CUDAStream& stream,
                                                        F&& body, const char* what,
                                                        const char* key) {
  auto graph = std::make_unique<at::cuda::CUDAGraph>();
  try {
    graph->capture_begin();
    body();  // recorded, not run
    graph->capture_end();
    std::fprintf(stderr, "bidex: %s: replayed as a CUDA graph\n", what);
    return graph;
  } catch (const std::exception& e) {
    cudaStreamCaptureStatus status = cudaStreamCaptureStatusNone;
    if (cudaStreamIsCapturing(stream.stream(), &status) == cudaSuccess &&
        status != cudaStreamCaptureStatusNone) {
      cudaGraph_t broken = nullptr;
      cudaStreamEndCapture(stream.stream(), &broken);
      if (broken) cudaGraphDestroy(broken);
    }
    (void)cudaGetLastError();
    std::fprintf(stderr,
                 "bidex: warning: %s could not be captured as a CUDA graph and runs without one "
                 "(%s: false hides this): %s\n",
                 what, key, std::string(e.what()).substr(0, 300).c_str());
    return nullptr;
  }
}

}  // namespace bidex::rl
#endif
