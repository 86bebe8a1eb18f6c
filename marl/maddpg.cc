// Placeholder until MADDPG lands (issue 18 integration branch).
#include "core/error.h"
#include "marl/algorithms.h"

namespace bidex::marl {
std::unique_ptr<rl::Algorithm> make_maddpg(const rl::TrainConfig&, int64_t, int64_t, int64_t,
                                           const torch::Device&) {
  throw Error("maddpg is not built yet");
}
}  // namespace bidex::marl
