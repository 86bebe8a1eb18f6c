#include "metarl/task_scale.h"

#include <sstream>
#include <stdexcept>
#include <string>

#include "rl/policy.h"

namespace bidex::metarl {

TaskReturnScale::TaskReturnScale(int64_t nslot, double gamma, const torch::Device& device)
    : nslot_(nslot), gamma_(gamma) {
  slot_return_ = torch::zeros({nslot}, torch::TensorOptions(torch::kFloat64).device(device));
  set_slot_tasks(std::vector<int>(nslot, 0), 1);
}

void TaskReturnScale::set_slot_tasks(const std::vector<int>& slot_task, int ntasks) {
  if (static_cast<int64_t>(slot_task.size()) != nslot_ || ntasks < 1)
    throw std::invalid_argument("task reward scale: " + std::to_string(slot_task.size()) +
                                " slot tasks for " + std::to_string(nslot_) + " slots");
  const auto f64 = slot_return_.options();
  std::vector<int64_t> ids(slot_task.begin(), slot_task.end());
  for (auto id : ids)
    if (id < 0 || id >= ntasks)
      throw std::invalid_argument("task reward scale: slot task " + std::to_string(id) +
                                  " outside 0.." + std::to_string(ntasks - 1));
  slot_task_ = torch::tensor(ids, torch::kLong).to(f64.device());
  task_slots_ = torch::zeros({ntasks}, f64).index_add_(0, slot_task_, torch::ones({nslot_}, f64));
  count_ = torch::zeros({ntasks}, f64);
  mean_ = torch::zeros({ntasks}, f64);
  var_ = torch::ones({ntasks}, f64);
}

torch::Tensor TaskReturnScale::stats() const {
  return torch::stack({count_, mean_, var_}).to(torch::kCPU);
}

void TaskReturnScale::set_stats(const torch::Tensor& stats) {
  if (stats.dim() != 2 || stats.size(0) != 3 || stats.size(1) != count_.size(0)) {
    std::ostringstream got;
    got << stats.sizes();
    throw std::invalid_argument("task return statistics of shape [3, " +
                                std::to_string(count_.size(0)) + "] expected, got " + got.str());
  }
  const auto s = stats.to(count_.options());
  count_.copy_(s[0]);
  mean_.copy_(s[1]);
  var_.copy_(s[2]);
}

void TaskReturnScale::save(torch::serialize::OutputArchive& root) const {
  root.write("task_return_stats", stats());
}

void TaskReturnScale::load(torch::serialize::InputArchive& root) {
  torch::Tensor s;
  root.read("task_return_stats", s);
  set_stats(s);
}

torch::Tensor TaskReturnScale::scaled(const torch::Tensor& reward, const torch::Tensor& done) {
  torch::NoGradGuard ng;
  const auto r = reward.to(torch::kFloat64);
  slot_return_ = slot_return_ * gamma_ + r;
  const auto per = task_slots_.clamp_min(1);
  const auto bmean = torch::zeros_like(mean_).index_add_(0, slot_task_, slot_return_) / per;
  const auto dev = slot_return_ - bmean.index_select(0, slot_task_);
  const auto bvar = torch::zeros_like(var_).index_add_(0, slot_task_, dev * dev) / per;
  rl::merge_moments(count_, mean_, var_, task_slots_, bmean, bvar);
  slot_return_ = slot_return_ * (1 - done.to(torch::kFloat64));
  // clipped: early on a task's returns may all be alike (a variance near zero)
  const auto std = (var_ + 1e-8).sqrt().index_select(0, slot_task_);
  return (r / std).clamp(-kMaxScaled, kMaxScaled).to(reward.scalar_type());
}

torch::Tensor discounted_returns(const torch::Tensor& rewards, const torch::Tensor& dones,
                                 double gamma) {
  torch::NoGradGuard ng;
  const auto r = rewards.to(torch::kFloat64), d = dones.to(torch::kFloat64);
  auto out = torch::empty_like(r);
  auto g = torch::zeros_like(r[0]);
  for (int64_t t = 0; t < r.size(0); ++t) {
    g = g * gamma + r[t];
    out[t] = g;
    g = g * (1 - d[t]);
  }
  return out;
}

}  // namespace bidex::metarl
