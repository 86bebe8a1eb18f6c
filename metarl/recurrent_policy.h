// RL^2's policy (Duan et al. 2016, "RL^2: Fast Reinforcement Learning via Slow Reinforcement
// Learning"; Wang et al. 2016, "Learning to Reinforcement Learn"): a GRU reads, at each step,
// the observation with the previous action, reward and done flag, and its hidden state is the
// policy's memory of the task so far. It is kept across the episodes of one task and cleared
// only where a new task starts, so adapting to a task is just running the network.
#pragma once

#include <cstdint>
#include <tuple>

#include <torch/torch.h>

#include "rl/policy.h"

namespace bidex::metarl {

// One input row per slot: [obs, prev_action, prev_reward, prev_done], for any leading shape:
// obs [..., D], prev_action [..., A], prev_reward [...], prev_done [...] -> [..., D + A + 2]
// (in obs's dtype). At a task's first step the previous action, reward and done are zeros.
torch::Tensor rl2_input(const torch::Tensor& obs, const torch::Tensor& prev_action,
                        const torch::Tensor& prev_reward, const torch::Tensor& prev_done);

// symlog(r) = sign(r) log(1 + |r|): rewards of any scale as inputs of similar size, with no
// statistics to keep, so it means the same on a task never seen in training.
torch::Tensor symlog(const torch::Tensor& x);

// A one-layer GRU of `hidden_size` over rl2_input rows, then linear heads: the Gaussian's mean
// (orthogonal, gain 0.01, as rl::ActorCritic's actor output) and the value (gain 1), with a
// learned state-independent log-std (initially log init_std). The GRU keeps LibTorch's default
// initialisation. With `input_norm` the rows it reads (input()) hold the observations
// normalised by a running mean and std (a buffer of the module, saved with it) and the previous
// reward as symlog. Throws std::invalid_argument on non-positive sizes or init_std.
class RecurrentPolicyImpl : public torch::nn::Module {
 public:
  RecurrentPolicyImpl(int64_t obs_dim, int64_t act_dim, int64_t hidden_size, double init_std,
                      bool input_norm = false);

  // The row the GRU reads, [N, input_dim()]: rl2_input of the observations and the previous
  // action, reward and done, with input_norm's transforms.
  torch::Tensor input(const torch::Tensor& obs, const torch::Tensor& prev_action,
                      const torch::Tensor& prev_reward, const torch::Tensor& prev_done) const;
  // Adds observations [N, obs_dim] to the running mean and std (training; no-op without
  // input_norm).
  void update_input_norm(const torch::Tensor& obs);

  // input [N, input_dim()], hidden [1, N, H] -> (mean [N, A], value [N], new hidden [1, N, H]).
  std::tuple<torch::Tensor, torch::Tensor, torch::Tensor> forward_step(
      const torch::Tensor& input, const torch::Tensor& hidden);
  // inputs [T, N, input_dim()], hidden0 [1, N, H], resets [T, N] (1 where a new task starts at
  // step t, else 0) -> (means [T, N, A], values [T, N], hiddens [T, N, H], the hidden state
  // after each step). Before step t the hidden state is multiplied by (1 - resets[t]): a reset
  // starts slot n from zeros, and no gradient crosses it. Episode ends are not resets: within a
  // task the memory carries over episodes, and prev_done in the input marks them.
  std::tuple<torch::Tensor, torch::Tensor, torch::Tensor> forward_sequence(
      const torch::Tensor& inputs, const torch::Tensor& hidden0, const torch::Tensor& resets);

  // Zeros [1, n, H] in the module's dtype and device: the hidden state of a new task.
  torch::Tensor initial_hidden(int64_t n) const;
  torch::Tensor log_std() const { return log_std_; }
  int64_t obs_dim() const { return obs_dim_; }
  int64_t act_dim() const { return act_dim_; }
  int64_t hidden_size() const { return hidden_size_; }
  int64_t input_dim() const { return obs_dim_ + act_dim_ + 2; }
  bool input_norm() const { return !obs_norm_.is_empty(); }

 private:
  int64_t obs_dim_, act_dim_, hidden_size_;
  rl::RunningNorm obs_norm_{nullptr};
  torch::nn::GRU gru_{nullptr};
  torch::nn::Linear mean_head_{nullptr}, value_head_{nullptr};
  torch::Tensor log_std_;
};
TORCH_MODULE(RecurrentPolicy);

}  // namespace bidex::metarl
