// Compile check of the stage bodies for the device: one kernel per converted family calls its
// four bodies with float rows, so a build with CUDA proves they compile for the GPU. Nothing
// launches these kernels (the GPU backend has its own).
#include "tasks/catch_body.h"
#include "tasks/handle_body.h"

namespace bidex::tasks {

__global__ void catch_body_check(const CatchProgram* prog, sim::WorldRows<float> w,
                                 sim::ResetRows<float> r, SlotState* st, SlotRng* rng,
                                 const float* act, float* obs, float* terms, int* done) {
  const int s = blockIdx.x * blockDim.x + threadIdx.x;
  SlotRng g = rng[s];
  catch_reset(*prog, r, st[s], g);
  catch_apply_actions(*prog, act, w);
  done[s] = catch_evaluate(*prog, w, st[s], terms);
  catch_observe(*prog, w, st[s], obs);
  rng[s] = g;
}

__global__ void handle_body_check(const HandleProgram* prog, sim::WorldRows<float> w,
                                  sim::ResetRows<float> r, SlotState* st, SlotRng* rng,
                                  const float* act, float* obs, float* terms, int* done) {
  const int s = blockIdx.x * blockDim.x + threadIdx.x;
  handle_reset(*prog, r, st[s], rng[s]);
  handle_apply_actions(*prog, act, w);
  done[s] = handle_evaluate(*prog, w, st[s], terms);
  handle_observe(*prog, w, st[s], obs);
}

}  // namespace bidex::tasks
