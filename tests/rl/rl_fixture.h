// Helpers of the learning tests: small training configurations on real task YAML, the bidex
// binary run as a user would, and file checks. No std::filesystem (LibTorch exports its own).
#pragma once

// LibTorch first: Debian's LibTorch pulls in glog, whose CHECK macro would replace Catch's
#include <torch/torch.h>
#undef CHECK

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <sys/wait.h>

#include <catch2/catch.hpp>

#include "core/files.h"
#include "rl/algorithms.h"
#include "rl/config.h"
#include "rl/trainer.h"
#include "tests/run_command.h"
#include "tests/tasks/task_fixture.h"

namespace bidex::test {

inline bool file_exists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0;
}

// A tiny on-policy configuration (ppo, mtppo, trpo, mttrpo) on a real task or suite: networks
// of 32, few slots, 2 updates by default; `extra` overrides come last and win.
inline std::string tiny_onpolicy_yaml(const std::string& algo, const std::string& target,
                                      std::vector<std::string> extra = {}) {
  const std::string s = rl::find_algorithm(algo).section;
  std::vector<std::string> o = {"env.slots=4",     "env.threads=1",         "train.steps=64",
                                s + ".hidden=[32]", s + ".horizon=8",         s + ".minibatches=2",
                                s + ".epochs=2",   "train.save_interval=1", "train.device=cpu",
                                "train.torch_threads=1"};
  for (auto& e : extra) o.push_back(e);
  return rl::resolve_train_yaml(rl::default_train_config(algo), algo, target, o);
}

// The same for PPO on a task.
inline std::string tiny_yaml(const std::string& task, std::vector<std::string> extra = {}) {
  return tiny_onpolicy_yaml("ppo", task, std::move(extra));
}

// Training options of tests: no progress bar.
inline rl::TrainOptions quiet() {
  rl::TrainOptions o;
  o.progress = false;
  return o;
}

// Largest |a - b| over the two modules' parameters, in order (two copies of one network).
inline double max_param_diff(torch::nn::Module& a, torch::nn::Module& b) {
  double worst = 0;
  auto pa = a.parameters(), pb = b.parameters();
  for (size_t k = 0; k < pa.size(); ++k)
    worst = std::max(worst, (pa[k] - pb[k]).abs().max().item<double>());
  return worst;
}

}  // namespace bidex::test
