// The width of a suite pack's one-hot task id, for the learners that read each row's task from
// it (mtsac's temperatures, mtppo's per-task advantages and returns).
#pragma once

#include <cstdint>
#include <string>

#include "core/error.h"
#include "rl/config.h"
#include "taskpack/suite.h"

namespace bidex::rl {

// The suite's train tasks (taskpack::suite_pack gives the one-hot that many columns), checked
// against the observation width; `who` names the learner and setting in the error.
inline int64_t suite_task_count(const TrainConfig& config, int64_t obs_dim,
                                const std::string& who) {
  const int64_t ntasks =
      static_cast<int64_t>(taskpack::load_suite(config.suite).train.size());
  if (ntasks < 1 || ntasks >= obs_dim)
    throw Error(who + ": suite " + config.suite + " has " + std::to_string(ntasks) +
                " train tasks for observations of " + std::to_string(obs_dim));
  return ntasks;
}

}  // namespace bidex::rl
