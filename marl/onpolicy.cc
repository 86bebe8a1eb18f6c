// Placeholder until the on-policy family lands (issue 18 integration branch).
#include "core/error.h"
#include "marl/algorithms.h"

namespace bidex::marl {
#define BIDEX_PENDING(name)                                                                    \
  std::unique_ptr<rl::Algorithm> make_##name(const rl::TrainConfig&, int64_t, int64_t, int64_t, \
                                             const torch::Device&) {                           \
    throw Error(#name " is not built yet");                                                    \
  }
BIDEX_PENDING(ippo)
BIDEX_PENDING(mappo)
BIDEX_PENDING(happo)
BIDEX_PENDING(hatrpo)
}  // namespace bidex::marl
