// The task families whose stages run on the GPU backend, listed once: a label and the task class,
// a BodyTask whose Bodies (tasks/body_task.h) the per-world functions call and whose bind()
// builds the program. WarpTaskEnv's host loop (warp_env.cc) and its CUDA kernels
// (warp_stages.cu) both expand this list; a family joins the GPU path with one line here.
#pragma once

#include "tasks/block_stack/block_stack.h"
#include "tasks/bottle_cap/bottle_cap.h"
#include "tasks/catch_family.h"
#include "tasks/grasp_and_place/grasp_and_place.h"
#include "tasks/handle_family.h"
#include "tasks/push_block/push_block.h"
#include "tasks/re_orientation/re_orientation.h"
#include "tasks/table_family.h"

#define BIDEX_GPU_FAMILIES(X)       \
  X(Catch, CatchTask)               \
  X(Handle, HandleTask)             \
  X(BottleCap, BottleCap)           \
  X(PushBlock, PushBlock)           \
  X(ReOrientation, ReOrientation)   \
  X(BlockStack, BlockStack)         \
  X(GraspAndPlace, GraspAndPlace)   \
  X(Table, TableTask)
