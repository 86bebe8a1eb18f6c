// The multi-agent family on the learning core: `bidex train --task T --algo
// ippo|mappo|happo|hatrpo|maddpg --agents hand|finger|FILE`. Each algorithm is an rl::Algorithm
// over the task's full observation and action rows: it splits the observation into its agents'
// views (marl/agents.h), lets every agent act on its own columns and assembles the action rows,
// so the collector, runner, checkpoints, eval, render and the registry are the learning core's.
// register_algorithms() adds them to rl's algorithm registry (rl::TrainsOn::kTask).
#pragma once

#include <memory>

#include "rl/algorithm.h"

namespace bidex::marl {

// Adds ippo, mappo, happo, hatrpo and maddpg to rl's registry; later calls do nothing.
void register_algorithms();

// The factories (the config's section: rl::TrainConfig::section_yaml; the agents: run_agents in
// marl/config.h, which refuses a split whose widths differ from obs_dim / act_dim).
std::unique_ptr<rl::Algorithm> make_ippo(const rl::TrainConfig& config, int64_t obs_dim,
                                         int64_t act_dim, int64_t nslot,
                                         const torch::Device& device);
std::unique_ptr<rl::Algorithm> make_mappo(const rl::TrainConfig& config, int64_t obs_dim,
                                          int64_t act_dim, int64_t nslot,
                                          const torch::Device& device);
std::unique_ptr<rl::Algorithm> make_happo(const rl::TrainConfig& config, int64_t obs_dim,
                                          int64_t act_dim, int64_t nslot,
                                          const torch::Device& device);
std::unique_ptr<rl::Algorithm> make_hatrpo(const rl::TrainConfig& config, int64_t obs_dim,
                                           int64_t act_dim, int64_t nslot,
                                           const torch::Device& device);
std::unique_ptr<rl::Algorithm> make_maddpg(const rl::TrainConfig& config, int64_t obs_dim,
                                           int64_t act_dim, int64_t nslot,
                                           const torch::Device& device);

}  // namespace bidex::marl
