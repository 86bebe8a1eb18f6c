// Capturing a learner's step as a CUDA graph, with the fallback every user of it shares: where
// the capture fails, the open capture is ended, a warning names the setting that turns the graph
// off, and the caller runs the step eagerly from then on. CUDA builds only (BIDEX_TORCH_CUDA).
#pragma once

#ifdef BIDEX_TORCH_CUDA
#include <cstdio>
#include <exception>
#include <memory>
#include <string>

#include <ATen/cuda/CUDAEvent.h>
#include <ATen/cuda/CUDAGraph.h>
#include <c10/cuda/CUDAGuard.h>
#include <c10/cuda/CUDAStream.h>
#include <cuda_runtime.h>

namespace bidex::rl {

// Records body() (which must read nothing back from the device) into a new graph on `stream`,
// the current stream of the caller's CUDAStreamGuard. Returns the graph, or null where the
// capture failed. `what` names the step in the messages ("PPO's minibatch step"), `key` the
// setting that turns the graph off ("ppo.cuda_graph"). `pool`: another graph's memory pool
// (CUDAGraph::pool()) to share, for graphs that never run at the same time; {0, 0}: its own.
template <class F>
std::unique_ptr<at::cuda::CUDAGraph> capture_cuda_graph(const c10::cuda::CUDAStream& stream,
                                                        F&& body, const char* what,
                                                        const char* key,
                                                        at::cuda::MempoolId_t pool = {0, 0}) {
  auto graph = std::make_unique<at::cuda::CUDAGraph>();
  try {
    graph->capture_begin(pool);
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

// A learner's step replayed as one CUDA graph, as PPO's minibatch step (rl/ppo.cc): the first
// call runs the steps eagerly on a side stream, the second captures them there and replays them,
// and every later call replays the graph. The steps must be the same sequence at every call and
// read nothing back; they read their inputs where they are (tensors that keep their addresses)
// and draw random numbers from the CUDA generator's graph-safe state. The caller rebinds its
// FlatAdam parameters before each call (a replay runs no host code). TD3's, DDPG's and SAC's
// updates (rl/td3.cc, rl/sac.cc: the replay buffer full, so that the sampled range is fixed) and
// PPO's act step, one per step of the rollout (rl/onpolicy.cc).
class GraphedSteps {
 public:
  // `what` and `key` as capture_cuda_graph's; `pool` a memory pool shared with graphs that never
  // run at the same time as this one (at::cuda::graph_pool_handle()), {0, 0}: its own
  GraphedSteps(const char* what, const char* key, at::cuda::MempoolId_t pool = {0, 0})
      : what_(what), key_(key), pool_(pool) {}

  // Runs steps() as above, the caller's stream waiting for it. Returns false where the capture
  // failed (steps() then ran eagerly; the caller turns its setting off).
  template <class F>
  bool run(F&& steps) {
    const auto main = c10::cuda::getCurrentCUDAStream();
    ready_.record(main);
    ready_.block(stream_);
    bool captured = true;
    {
      c10::cuda::CUDAStreamGuard on_side(stream_);
      if (warm_ && !graph_) {
        graph_ = capture_cuda_graph(stream_, steps, what_, key_, pool_);
        captured = graph_ != nullptr;
      }
      if (graph_)
        graph_->replay();
      else
        steps();
      warm_ = true;
    }
    done_.record(stream_);
    done_.block(main);
    return captured;
  }

 private:
  const char* what_;
  const char* key_;
  at::cuda::MempoolId_t pool_;
  c10::cuda::CUDAStream stream_ = c10::cuda::getStreamFromPool();
  at::cuda::CUDAEvent ready_, done_;  // the side stream waits for the caller's, and back
  std::unique_ptr<at::cuda::CUDAGraph> graph_;
  bool warm_ = false;
};

}  // namespace bidex::rl
#endif
