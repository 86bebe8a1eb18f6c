#include "rl/replay.h"

#include "core/error.h"

namespace bidex::rl {

ReplayBuffer::ReplayBuffer(int64_t capacity, int64_t obs_dim, int64_t act_dim,
                           const torch::Device& device)
    : capacity_(capacity) {
  if (capacity < 1)
    throw Error("replay buffer: capacity must be at least 1 row, got " + std::to_string(capacity));
  auto f = torch::TensorOptions().dtype(torch::kFloat32).device(device);
  obs_ = torch::zeros({capacity, obs_dim}, f);
  actions_ = torch::zeros({capacity, act_dim}, f);
  rewards_ = torch::zeros({capacity}, f);
  next_obs_ = torch::zeros({capacity, obs_dim}, f);
  terminal_ = torch::zeros({capacity}, f);
}

void ReplayBuffer::add(const torch::Tensor& obs, const torch::Tensor& actions,
                       const torch::Tensor& rewards, const torch::Tensor& next_obs,
                       const torch::Tensor& terminal) {
  const int64_t n = obs.size(0);
  if (n > capacity_)
    throw Error("replay buffer: one step of " + std::to_string(n) + " slots does not fit its " +
                std::to_string(capacity_) + " rows");
  torch::NoGradGuard ng;
  // rows next_, next_ + 1, ...: one slice, or two where they wrap round to the start
  const int64_t first = std::min(n, capacity_ - next_);
  auto put = [&](torch::Tensor& dst, const torch::Tensor& src) {
    dst.narrow(0, next_, first).copy_(src.narrow(0, 0, first));
    if (first < n) dst.narrow(0, 0, n - first).copy_(src.narrow(0, first, n - first));
  };
  put(obs_, obs);
  put(actions_, actions);
  put(rewards_, rewards);
  put(next_obs_, next_obs);
  put(terminal_, terminal);
  next_ = (next_ + n) % capacity_;
  size_ = std::min(capacity_, size_ + n);
}

void ReplayBuffer::add(const torch::Tensor& obs, const torch::Tensor& actions,
                       const Transition& t, double reward_scale) {
  torch::NoGradGuard ng;
  auto next_obs = t.obs;
  auto terminal = t.done;
  if (t.final_ids.numel() > 0) {
    next_obs = t.obs.index_copy(0, t.final_ids, t.final_obs);
    terminal = t.done.index_fill(0, t.final_ids, 0.f);
  }
  add(obs, actions, reward_scale == 1.0 ? t.reward : t.reward * reward_scale, next_obs, terminal);
}

ReplayBuffer::Batch ReplayBuffer::sample(int64_t n) const {
  if (size_ == 0) throw Error("replay buffer: sampling from an empty buffer");
  torch::NoGradGuard ng;
  const auto idx = torch::randint(size_, {n}, torch::TensorOptions().dtype(torch::kLong).device(
                                                  obs_.device()));
  return {obs_.index_select(0, idx), actions_.index_select(0, idx),
          rewards_.index_select(0, idx), next_obs_.index_select(0, idx),
          terminal_.index_select(0, idx)};
}

}  // namespace bidex::rl
