#include "rl/stage_timer.h"

#include <torch/cuda.h>

namespace bidex::rl {

void StageTimer::enable(const torch::Device& device) {
  on_ = true;
  device_ = device;
}

void StageTimer::wait() const {
  if (device_.is_cuda()) torch::cuda::synchronize(device_.index());
}

void StageTimer::start() {
  if (!on_) return;
  wait();
  last_ = std::chrono::steady_clock::now();
}

void StageTimer::mark(const char* stage) {
  if (!on_) return;
  wait();
  const auto now = std::chrono::steady_clock::now();
  seconds_[stage] += std::chrono::duration<double>(now - last_).count();
  last_ = now;
}

std::map<std::string, double> StageTimer::totals() const {
  auto t = seconds_;
  if (on_) t["host_syncs"] = static_cast<double>(syncs_);
  return t;
}

}  // namespace bidex::rl
