// A pack's observation row from its task's, written once for the CPU pack's loop and the GPU
// pack's kernel: kept values pass through, padding and masked goal slices are zeros, and the
// entry's one-hot bit is set (multi-task mode).
#pragma once

#include <cstdint>

#include "core/hd.h"

namespace bidex::taskpack {

// `keep` has `pad` values and is 0 past the task's own width, so `src` is never read beyond its
// row; `hot` is the one-hot column (-1: none); `dst` has `width` values.
template <class Real>
BIDEX_HD inline void pack_row(const Real* src, const uint8_t* keep, int pad, int width, int hot,
                              Real* dst) {
  for (int i = 0; i < pad; ++i) dst[i] = keep[i] ? src[i] : Real(0);
  for (int i = pad; i < width; ++i) dst[i] = Real(0);
  if (hot >= 0) dst[hot] = Real(1);
}

// One entry's rows of a GPU pack step (taskpack/warp_pack.h): the task's outputs in, the pack's
// out, one call per slot of the entry.
struct EntryRows {
  // the entry's task (one row per world of its scene)
  const float* obs = nullptr;
  const float* final_obs = nullptr;
  const float* reward = nullptr;
  const uint8_t* terminated = nullptr;
  const uint8_t* truncated = nullptr;
  const uint8_t* faulted = nullptr;
  const uint8_t* keep = nullptr;  // Pack::obs_keep of the entry, in device memory
  int task_obs_dim = 0, n = 0, begin = 0, hot = -1;
  double scale = 1;
  // the pack's (one row per pack slot)
  int pad = 0, width = 0;
  float* pack_obs = nullptr;
  float* pack_final_obs = nullptr;
  float* pack_reward = nullptr;
  float* pack_done = nullptr;       // 1 where the episode ended at this step, either way
  float* pack_bootstrap = nullptr;  // 1 where the time limit cut it and the world did not fault
};

BIDEX_HD inline void pack_slot(const EntryRows& e, int local) {
  const long src = static_cast<long>(local) * e.task_obs_dim;
  const int slot = e.begin + local;
  const long dst = static_cast<long>(slot) * e.width;
  pack_row(e.obs + src, e.keep, e.pad, e.width, e.hot, e.pack_obs + dst);
  e.pack_reward[slot] = static_cast<float>(static_cast<double>(e.reward[local]) * e.scale);
  const bool done = e.terminated[local] || e.truncated[local];
  e.pack_done[slot] = done ? 1.f : 0.f;
  e.pack_bootstrap[slot] = (e.truncated[local] && !e.faulted[local]) ? 1.f : 0.f;
  if (done) pack_row(e.final_obs + src, e.keep, e.pad, e.width, e.hot, e.pack_final_obs + dst);
}

}  // namespace bidex::taskpack
