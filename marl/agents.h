// Agents of the multi-agent setting on LibTorch: the split a checkpoint was trained with, and
// each agent's view of a batch on a device. The splits themselves: marl/split.h.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <torch/torch.h>

#include "marl/split.h"

namespace bidex::marl {

// Checkpoints hold the split they were trained with (each agent's observation and action
// columns): write_split adds it to an archive, check_split refuses an archive of another split
// with an Error naming `path` and both splits' agents and widths.
void write_split(torch::serialize::OutputArchive& root, const AgentSplit& split);
void check_split(torch::serialize::InputArchive& root, const AgentSplit& split,
                 const std::string& path);

// The split on a device: each agent's view of a batch of full observations, and the full action
// rows assembled from the agents' own.
class AgentViews {
 public:
  AgentViews(const AgentSplit& split, const torch::Device& device);
  int64_t count() const { return static_cast<int64_t>(obs_idx_.size()); }
  int64_t obs_dim(int64_t i) const { return obs_idx_[i].numel(); }
  int64_t act_dim(int64_t i) const { return act_idx_[i].numel(); }
  // [..., D] full observations -> [..., obs_dim(i)] what agent i sees
  torch::Tensor obs(const torch::Tensor& full, int64_t i) const;
  // [..., A] full actions -> [..., act_dim(i)] agent i's part
  torch::Tensor actions(const torch::Tensor& full, int64_t i) const;
  // The agents' actions [..., act_dim(i)], in agent order -> [..., A]
  torch::Tensor assemble(const std::vector<torch::Tensor>& parts) const;
  const AgentSplit& split() const { return split_; }

 private:
  AgentSplit split_;
  std::vector<torch::Tensor> obs_idx_, act_idx_;  // long, on the device
  int64_t act_dim_ = 0;
};

}  // namespace bidex::marl
