// Helpers of the learning tests: small training configurations on real task YAML, the bidex
// binary run as a user would, and file checks. No std::filesystem (LibTorch exports its own).
#pragma once

// LibTorch first: Debian's LibTorch pulls in glog, whose CHECK macro would replace Catch's
#include <torch/torch.h>
#undef CHECK

#include <cstdio>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <sys/wait.h>

#include <catch2/catch.hpp>

#include "core/files.h"
#include "rl/config.h"
#include "tests/run_command.h"
#include "tests/tasks/task_fixture.h"

namespace bidex::test {

inline bool file_exists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0;
}

// A tiny PPO configuration on a real task (networks of 32, few slots, 2 updates by default).
inline std::string tiny_yaml(const std::string& task, std::vector<std::string> extra = {}) {
  std::vector<std::string> o = {"env.slots=4",       "env.threads=1",        "train.steps=64",
                                "ppo.hidden=[32]",   "ppo.horizon=8",        "ppo.minibatches=2",
                                "ppo.epochs=2",      "train.save_interval=1", "train.device=cpu",
                                "train.torch_threads=1"};
  for (auto& e : extra) o.push_back(e);
  return rl::resolve_train_yaml(rl::default_train_config("ppo"), "ppo", task, o);
}

// The same for TRPO (its own `trpo:` section).
inline std::string tiny_trpo_yaml(const std::string& task, std::vector<std::string> extra = {}) {
  std::vector<std::string> o = {"env.slots=4",       "env.threads=1",        "train.steps=64",
                                "trpo.hidden=[32]",  "trpo.horizon=8",       "trpo.minibatches=2",
                                "trpo.epochs=2",     "train.save_interval=1", "train.device=cpu",
                                "train.torch_threads=1"};
  for (auto& e : extra) o.push_back(e);
  return rl::resolve_train_yaml(rl::default_train_config("trpo"), "trpo", task, o);
}

}  // namespace bidex::test
