// The off-policy storage of the learning core: a ring buffer of transitions on the training
// device (with CUDA, on the GPU: adding and sampling never leave it). Each add() writes one step
// of every slot; once full, the oldest rows are overwritten. sample() draws rows uniformly with
// replacement, on the device, from LibTorch's generator (seeded by the run's seed).
#pragma once

#include <torch/torch.h>

#include "rl/algorithm.h"

namespace bidex::rl {

class ReplayBuffer {
 public:
  ReplayBuffer(int64_t capacity, int64_t obs_dim, int64_t act_dim, const torch::Device& device);

  // One step of n slots: obs [n, D], actions [n, A], rewards [n], next_obs [n, D], terminal [n]
  // (1 where the episode ended by itself: no bootstrap from next_obs). n may not exceed the
  // capacity (an Error naming both).
  void add(const torch::Tensor& obs, const torch::Tensor& actions, const torch::Tensor& rewards,
           const torch::Tensor& next_obs, const torch::Tensor& terminal);
  // The step that took `obs` with `actions` to the collector's transition `t`: a slot whose
  // episode ended keeps its last observation as next_obs where the time limit cut it (and is
  // then not terminal); one that ended otherwise is terminal. Rewards are stored times
  // `reward_scale`.
  void add(const torch::Tensor& obs, const torch::Tensor& actions, const Transition& t,
           double reward_scale = 1.0);

  struct Batch {
    torch::Tensor obs, actions, rewards, next_obs, terminal;
  };
  // n rows drawn uniformly with replacement from those stored (an Error when empty).
  Batch sample(int64_t n) const;

  int64_t size() const { return size_; }
  int64_t capacity() const { return capacity_; }

 private:
  int64_t capacity_, size_ = 0, next_ = 0;
  torch::Tensor obs_, actions_, rewards_, next_obs_, terminal_;
};

}  // namespace bidex::rl
