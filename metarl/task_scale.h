// task_reward_norm of the meta-learners (RL^2, MAML, ProMP): a suite's tasks pay rewards that
// differ by orders of magnitude, so each task's rewards are divided by the running std of its
// own discounted returns before advantages and critic targets, and clipped per step. The
// policies never see the scale.
#pragma once

#include <vector>

#include <torch/torch.h>

namespace bidex::metarl {

class TaskReturnScale {
 public:
  static constexpr double kMaxScaled = 10;  // the clip of a scaled reward, per step

  TaskReturnScale(int64_t nslot, double gamma, const torch::Device& device);
  // Each slot's task (0 .. ntasks - 1); clears the statistics. By default every slot is task 0.
  void set_slot_tasks(const std::vector<int>& slot_task, int ntasks);
  // One step of every slot, rewards and done flags [N]: each slot's discounted return so far
  // joins its task's statistics (rl::merge_moments), then the rewards are divided by their
  // tasks' return std and clipped; a slot's return restarts after its episode ends.
  torch::Tensor scaled(const torch::Tensor& reward, const torch::Tensor& done);
  // Per task: the count, mean and variance of the returns seen, [3, ntasks] (float64, CPU);
  // checkpoints keep them.
  torch::Tensor stats() const;
  void set_stats(const torch::Tensor& stats);
  // The statistics as a checkpoint's entry `task_return_stats`, and back.
  void save(torch::serialize::OutputArchive& root) const;
  void load(torch::serialize::InputArchive& root);

 private:
  int64_t nslot_;
  double gamma_;
  torch::Tensor slot_task_, slot_return_;                  // [N] long, [N] float64
  torch::Tensor task_slots_, count_, mean_, var_;          // [ntasks] float64
};

// For the same scale measured on one batch of rows (evaluation, where a held-out task has no
// statistics): rewards and dones [T, N] -> each slot's discounted return so far [T, N] (float64),
// restarting after its episode ends, as TaskReturnScale accumulates it.
torch::Tensor discounted_returns(const torch::Tensor& rewards, const torch::Tensor& dones,
                                 double gamma);

}  // namespace bidex::metarl
