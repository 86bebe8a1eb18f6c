#include "marl/agents.h"

#include <string>
#include <vector>

#include "core/error.h"

namespace bidex::marl {

namespace {

// [agents, then per agent: obs width, act width, obs columns, act columns]
torch::Tensor split_tensor(const AgentSplit& split) {
  std::vector<int64_t> v = {static_cast<int64_t>(split.agents.size())};
  for (const auto& a : split.agents) {
    v.push_back(static_cast<int64_t>(a.obs_cols.size()));
    v.push_back(static_cast<int64_t>(a.act_cols.size()));
    v.insert(v.end(), a.obs_cols.begin(), a.obs_cols.end());
    v.insert(v.end(), a.act_cols.begin(), a.act_cols.end());
  }
  return torch::tensor(v, torch::kInt64);
}

// "2 agents of observation/action widths 211/20, 211/20"
std::string split_text(const torch::Tensor& t) {
  const auto v = t.to(torch::kCPU).contiguous();
  const auto* p = v.data_ptr<int64_t>();
  const int64_t n = v.numel();
  if (n == 0) return "no agents";
  std::string widths;
  int64_t at = 1;
  for (int64_t k = 0; k < p[0] && at + 1 < n; ++k) {
    widths += (k ? ", " : "") + std::to_string(p[at]) + "/" + std::to_string(p[at + 1]);
    at += 2 + p[at] + p[at + 1];
  }
  return std::to_string(p[0]) + " agents of observation/action widths " + widths;
}

}  // namespace

void write_split(torch::serialize::OutputArchive& root, const AgentSplit& split) {
  root.write("agents", split_tensor(split));
}

void check_split(torch::serialize::InputArchive& root, const AgentSplit& split,
                 const std::string& path) {
  torch::Tensor saved;
  root.read("agents", saved);
  saved = saved.to(torch::kCPU);
  const auto mine = split_tensor(split);
  if (saved.sizes().equals(mine.sizes()) && saved.equal(mine)) return;
  throw Error("checkpoint " + path + ": holds " + split_text(saved) + "; this run's " +
              split.kind + " split has " + split_text(mine) + " (another agents split?)");
}

AgentViews::AgentViews(const AgentSplit& split, const torch::Device& device)
    : split_(split), act_dim_(split.act_dim) {
  auto to_tensor = [&](const std::vector<int64_t>& v) {
    return torch::tensor(v, torch::kLong).to(device);
  };
  for (auto& a : split.agents) {
    obs_idx_.push_back(to_tensor(a.obs_cols));
    act_idx_.push_back(to_tensor(a.act_cols));
  }
}

torch::Tensor AgentViews::obs(const torch::Tensor& full, int64_t i) const {
  return full.index_select(-1, obs_idx_[i]);
}

torch::Tensor AgentViews::actions(const torch::Tensor& full, int64_t i) const {
  return full.index_select(-1, act_idx_[i]);
}

torch::Tensor AgentViews::assemble(const std::vector<torch::Tensor>& parts) const {
  auto sizes = parts.front().sizes().vec();
  sizes.back() = act_dim_;
  auto out = torch::empty(sizes, parts.front().options());
  for (size_t i = 0; i < parts.size(); ++i) out.index_copy_(-1, act_idx_[i], parts[i]);
  return out;
}

}  // namespace bidex::marl
