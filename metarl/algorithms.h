// The meta-RL family on the learning core: `bidex train --suite ML20 --algo maml|promp|rl2`
// meta-trains on a meta suite's train split, and `bidex eval --split` adapts and scores
// (rl/algorithm.h, Adaptive). register_algorithms() adds them to rl's algorithm registry.
#pragma once

#include <memory>

#include "rl/algorithm.h"

namespace bidex::metarl {

// Adds maml, promp and rl2 to rl's registry; later calls do nothing.
void register_algorithms();

// The factories (the config's section: TrainConfig::section_yaml).
std::unique_ptr<rl::Algorithm> make_maml(const rl::TrainConfig& config, int64_t obs_dim,
                                         int64_t act_dim, int64_t nslot,
                                         const torch::Device& device);
std::unique_ptr<rl::Algorithm> make_promp(const rl::TrainConfig& config, int64_t obs_dim,
                                          int64_t act_dim, int64_t nslot,
                                          const torch::Device& device);
std::unique_ptr<rl::Algorithm> make_rl2(const rl::TrainConfig& config, int64_t obs_dim,
                                        int64_t act_dim, int64_t nslot,
                                        const torch::Device& device);

}  // namespace bidex::metarl
