// Wall time per named stage of the learner, for `bidex train --profile` (profile.json's
// "learner"): when on, each mark waits for the device first, so that a stage's time holds its
// kernels; when off, a mark is one branch. Also counts the host synchronisations the learner
// makes on its own (a value read back from the device), which stall the GPU's queue.
#pragma once

#include <chrono>
#include <map>
#include <string>

#include <torch/torch.h>

namespace bidex::rl {

class StageTimer {
 public:
  void enable(const torch::Device& device);
  bool on() const { return on_; }
  // Starts timing from here (after waiting for the device).
  void start();
  // Adds the time since the last start() or mark() to `stage` (after waiting for the device).
  void mark(const char* stage);
  // `n` host synchronisations of the learner's own (profiled or not, they happen).
  void count_syncs(int64_t n) {
    if (on_) syncs_ += n;
  }
  // Seconds per stage, and "host_syncs": the count of synchronisations.
  std::map<std::string, double> totals() const;

 private:
  void wait() const;
  bool on_ = false;
  torch::Device device_ = torch::kCPU;
  std::chrono::steady_clock::time_point last_;
  std::map<std::string, double> seconds_;
  int64_t syncs_ = 0;
};

}  // namespace bidex::rl
