// The offline RL family on the learning core: `bidex train --dataset DIR --algo
// bc|bcq|td3bc|iql` learns from a dataset of one task (offline/dataset.h) while the run's pack
// only evaluates the policy (offline_algorithm.h). register_algorithms() adds them to rl's
// algorithm registry (TrainsOn::kDataset).
#pragma once

#include <memory>

#include "core/yaml.h"
#include "offline/offline_algorithm.h"

namespace bidex::offline {

// Adds bc, bcq, td3bc and iql to rl's registry; later calls do nothing.
void register_algorithms();

// The factories (the config's section: TrainConfig::section_yaml; the dataset is read only by
// prepare_training).
std::unique_ptr<OfflineAlgorithm> make_bc(const rl::TrainConfig& config, int64_t obs_dim,
                                          int64_t act_dim, int64_t nslot,
                                          const torch::Device& device);
std::unique_ptr<OfflineAlgorithm> make_bcq(const rl::TrainConfig& config, int64_t obs_dim,
                                           int64_t act_dim, int64_t nslot,
                                           const torch::Device& device);
std::unique_ptr<OfflineAlgorithm> make_td3bc(const rl::TrainConfig& config, int64_t obs_dim,
                                             int64_t act_dim, int64_t nslot,
                                             const torch::Device& device);
std::unique_ptr<OfflineAlgorithm> make_iql(const rl::TrainConfig& config, int64_t obs_dim,
                                           int64_t act_dim, int64_t nslot,
                                           const torch::Device& device);

// The config's section (TrainConfig::section_yaml) as a view naming it in errors.
YamlView section_of(const rl::TrainConfig& config);

}  // namespace bidex::offline
