// The offline algorithms' networks: ReLU perceptrons with either LibTorch's default
// initialisation (as the original's TD3+BC and BCQ, PyTorch's default) or orthogonal weights
// (IQL's), twin critics, and the dataset's observation normaliser.
#pragma once

#include <utility>
#include <vector>

#include <torch/torch.h>

namespace bidex::offline {

// Linear + ReLU per `hidden` width; `orthogonal_gain` > 0 replaces the default weights with
// orthogonal ones of that gain (biases keep the default).
torch::nn::Sequential relu_trunk(int64_t in, const std::vector<int>& hidden,
                                 double orthogonal_gain = 0);
// relu_trunk and a linear output layer of `out` (initialised alike).
torch::nn::Sequential relu_mlp(int64_t in, const std::vector<int>& hidden, int64_t out,
                               double orthogonal_gain = 0);

// Two critics Q(s, a) on the observation and action side by side.
struct TwinQImpl : torch::nn::Module {
  TwinQImpl(int64_t obs_dim, int64_t act_dim, const std::vector<int>& hidden,
            double orthogonal_gain = 0);
  // (q1, q2), each [n]
  std::pair<torch::Tensor, torch::Tensor> forward(const torch::Tensor& obs,
                                                  const torch::Tensor& act);
  torch::Tensor first(const torch::Tensor& obs, const torch::Tensor& act);  // q1 only
  torch::nn::Sequential q1{nullptr}, q2{nullptr};
};
TORCH_MODULE(TwinQ);

// (obs - mean) / std with the dataset's mean and std (buffers: saved with the actor); identity
// until set.
struct ObsNormImpl : torch::nn::Module {
  explicit ObsNormImpl(int64_t dim);
  torch::Tensor forward(const torch::Tensor& obs) const { return (obs - mean) / sd; }
  torch::Tensor mean, sd;  // buffers "mean" and "std"
};
TORCH_MODULE(ObsNorm);

// Target networks start as copies and never take gradients.
void make_target(torch::nn::Module& net, torch::nn::Module& target);

}  // namespace bidex::offline
