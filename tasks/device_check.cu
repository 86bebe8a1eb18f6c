// Compile check of the stage bodies for the device: one kernel per converted family calls its
// four bodies with float rows, so a build with CUDA proves they compile for the GPU. Nothing
// launches these kernels (the GPU backend has its own).
#include "tasks/block_stack/block_stack_body.h"
#include "tasks/bottle_cap/bottle_cap_body.h"
#include "tasks/catch_body.h"
#include "tasks/grasp_and_place/grasp_and_place_body.h"
#include "tasks/handle_body.h"
#include "tasks/push_block/push_block_body.h"
#include "tasks/re_orientation/re_orientation_body.h"
#include "tasks/table_body.h"

namespace bidex::tasks {

// <prefix>_body_check: the four bodies of one family, in the order of a step.
#define BIDEX_BODY_CHECK(Program, prefix)                                                     \
  __global__ void prefix##body_check(const Program* prog, sim::WorldRows<float> w,            \
                                     sim::ResetRows<float> r, SlotState* st, SlotRng* rng,    \
                                     const float* act, float* obs, float* terms, int* done) { \
    const int s = blockIdx.x * blockDim.x + threadIdx.x;                                      \
    SlotRng g = rng[s];                                                                       \
    prefix##reset(*prog, r, st[s], g);                                                        \
    prefix##apply_actions(*prog, act, w);                                                     \
    done[s] = prefix##evaluate(*prog, w, st[s], g, terms);                                    \
    prefix##observe(*prog, w, st[s], obs);                                                    \
    rng[s] = g;                                                                               \
  }

BIDEX_BODY_CHECK(CatchProgram, catch_)
BIDEX_BODY_CHECK(HandleProgram, handle_)
BIDEX_BODY_CHECK(BottleCapProgram, bottle_cap_)
BIDEX_BODY_CHECK(PushBlockProgram, push_block_)
BIDEX_BODY_CHECK(ReOrientationProgram, re_orientation_)
BIDEX_BODY_CHECK(BlockStackProgram, block_stack_)
BIDEX_BODY_CHECK(GraspAndPlaceProgram, grasp_and_place_)
BIDEX_BODY_CHECK(TableProgram, table_)

#undef BIDEX_BODY_CHECK

}  // namespace bidex::tasks
