// The collector: steps a task pack with the actions an algorithm chose and hands back what the
// step gave on the training device, in one transfer each way per step (with CUDA, from pinned
// host memory): the actions to the host, then one buffer of observations, rewards, done flags
// and the final observations of slots whose episode the time limit cut (for bootstrapping).
#pragma once

#include <torch/torch.h>

#include "rl/algorithm.h"

namespace bidex::taskpack {
class TaskPack;
}

namespace bidex::rl {

class Collector {
 public:
  Collector(taskpack::TaskPack& env, const torch::Device& device);
  // Resets every slot; the observations [N, D].
  torch::Tensor reset();
  // One control step of every slot with `actions` [N, A] (any device).
  Transition step(const torch::Tensor& actions);
  // Seconds spent inside the pack's step since the last call (what simulation costs).
  double take_sim_seconds();

 private:
  // copies the pack's outputs into the staging buffer and it to the device
  torch::Tensor upload(bool with_final, int* k_out);
  taskpack::TaskPack& env_;
  torch::Device device_;
  torch::Tensor staging_;
  torch::Tensor no_ids_, no_final_obs_;  // what a step that cut no episode hands back
  double sim_s_ = 0;
};

}  // namespace bidex::rl
