// The task families whose stages run on the GPU backend, listed once: each entry names the task
// class (its bind() builds the program), the program type and the prefix of its four stage
// bodies (<prefix>reset, <prefix>apply_actions, <prefix>evaluate, <prefix>observe). WarpTaskEnv's
// host loop (warp_env.cc) and its CUDA kernels (warp_stages.cu) both expand this list; a family
// joins the GPU path with one line here.
#pragma once

#include "core/hd.h"
#include "tasks/block_stack/block_stack.h"
#include "tasks/bottle_cap/bottle_cap.h"
#include "tasks/catch_family.h"
#include "tasks/grasp_and_place/grasp_and_place.h"
#include "tasks/handle_family.h"
#include "tasks/push_block/push_block.h"
#include "tasks/re_orientation/re_orientation.h"
#include "tasks/table_family.h"

#define BIDEX_GPU_FAMILIES(X)                                              \
  X(Catch, CatchTask, CatchProgram, catch_)                                \
  X(Handle, HandleTask, HandleProgram, handle_)                            \
  X(BottleCap, BottleCap, BottleCapProgram, bottle_cap_)                   \
  X(PushBlock, PushBlock, PushBlockProgram, push_block_)                   \
  X(ReOrientation, ReOrientation, ReOrientationProgram, re_orientation_)   \
  X(BlockStack, BlockStack, BlockStackProgram, block_stack_)               \
  X(GraspAndPlace, GraspAndPlace, GraspAndPlaceProgram, grasp_and_place_) \
  X(Table, TableTask, TableProgram, table_)

namespace bidex::tasks {

// One family's bodies behind the four names world_step.h calls.
#define BIDEX_GPU_BODIES(name, Task_, Program_, prefix)                                       \
  struct name##Bodies {                                                                       \
    using Task = Task_;                                                                       \
    using Program = Program_;                                                                 \
    template <class R>                                                                        \
    BIDEX_HD static void reset(const Program& p, const sim::ResetRows<R>& r, SlotState& st,   \
                               SlotRng& rng) {                                                \
      prefix##reset(p, r, st, rng);                                                           \
    }                                                                                         \
    template <class R>                                                                        \
    BIDEX_HD static void apply(const Program& p, const float* a, const sim::WorldRows<R>& w) { \
      prefix##apply_actions(p, a, w);                                                         \
    }                                                                                         \
    template <class R>                                                                        \
    BIDEX_HD static bool evaluate(const Program& p, const sim::WorldRows<R>& w, SlotState& st, \
                                  SlotRng& rng, R* terms) {                                   \
      return prefix##evaluate(p, w, st, rng, terms);                                          \
    }                                                                                         \
    template <class R>                                                                        \
    BIDEX_HD static void observe(const Program& p, const sim::WorldRows<R>& w,                \
                                 const SlotState& st, float* o) {                             \
      prefix##observe(p, w, st, o);                                                           \
    }                                                                                         \
  };
BIDEX_GPU_FAMILIES(BIDEX_GPU_BODIES)
#undef BIDEX_GPU_BODIES

}  // namespace bidex::tasks
