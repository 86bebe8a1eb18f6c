// The offline algorithms' networks: ReLU perceptrons with either LibTorch's default
// initialisation (as the original's TD3+BC and BCQ, PyTorch's default) or orthogonal weights
// (IQL's), twin critics, and the dataset's observation normaliser.
#pragma once

#include <utility>
#include <vector>

#include <torch/torch.h>

#include "rl/policy.h"

namespace bidex::offline {

// Linear + ReLU per `hidden` width; `orthogonal_gain` > 0 replaces the default weights with
// orthogonal ones of that gain (biases keep the default).
torch::nn::Sequential relu_trunk(int64_t in, const std::vector<int>& hidden,
                                 double orthogonal_gain = 0);
// relu_trunk and a linear output layer of `out` (initialised alike).
torch::nn::Sequential relu_mlp(int64_t in, const std::vector<int>& hidden, int64_t out,
                               double orthogonal_gain = 0);

// Twin critics Q(s, a) (rl::QCritic) of relu_mlp networks.
rl::QCritic twin_q(int64_t obs_dim, int64_t act_dim, const std::vector<int>& hidden,
                   double orthogonal_gain = 0);

// (obs - mean) / std with the dataset's mean and std (buffers: saved with the actor); identity
// until set.
struct ObsNormImpl : torch::nn::Module {
  explicit ObsNormImpl(int64_t dim);
  torch::Tensor forward(const torch::Tensor& obs) const { return (obs - mean) / sd; }
  torch::Tensor mean, sd;  // buffers "mean" and "std"
};
TORCH_MODULE(ObsNorm);

}  // namespace bidex::offline
