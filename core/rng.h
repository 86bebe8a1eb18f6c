// SlotRng: a slot's random stream, counter-based (Philox4x32-10) so that host and device code
// draw the same numbers from the same key: (run seed, slot, episode) and a draw counter. A copy
// of the 32-byte state is the whole stream; nothing is shared between slots or threads.
#pragma once

#include <cstdint>
#include <type_traits>

#include <Random123/philox.h>

#include "core/hd.h"

namespace bidex {

struct SlotRng {
  uint64_t seed = 0;     // run seed (Philox key)
  uint64_t episode = 0;  // resets of the slot so far
  uint32_t slot = 0;
  uint32_t pad = 0;
  uint64_t draw = 0;     // 64-bit values drawn since the key was set

  BIDEX_HD static SlotRng make(uint64_t seed, uint32_t slot, uint64_t episode) {
    SlotRng r;
    r.seed = seed;
    r.slot = slot;
    r.episode = episode;
    return r;
  }
  // A new key (a new episode): the counter starts again at 0.
  BIDEX_HD void rekey(uint64_t new_episode) {
    episode = new_episode;
    draw = 0;
  }
  // Draw n: half of the Philox block n / 2 under the counter (n / 2, slot, episode low, episode
  // high); 2^33 draws per episode before the stream repeats.
  BIDEX_HD uint64_t next_u64() {
    const uint64_t n = draw++;
    const uint64_t block = n >> 1;
    const philox4x32_ctr_t c = {{static_cast<uint32_t>(block), slot,
                                 static_cast<uint32_t>(episode),
                                 static_cast<uint32_t>(episode >> 32)}};
    const philox4x32_key_t k = {{static_cast<uint32_t>(seed), static_cast<uint32_t>(seed >> 32)}};
    const philox4x32_ctr_t r = philox4x32(c, k);
    const int h = static_cast<int>(n & 1) * 2;
    return (static_cast<uint64_t>(r.v[h]) << 32) | r.v[h + 1];
  }
  // Uniform in [lo, hi) from the top 53 bits of one draw.
  BIDEX_HD double uniform(double lo, double hi) {
    const double u = static_cast<double>(next_u64() >> 11) * 0x1.0p-53;
    return lo + (hi - lo) * u;
  }
};
static_assert(std::is_trivially_copyable_v<SlotRng>, "copied to the device as bytes");

}  // namespace bidex
