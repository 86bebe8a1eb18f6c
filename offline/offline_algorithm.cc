#include "offline/offline_algorithm.h"

#include "rl/checkpoint.h"

namespace bidex::offline {

OfflineAlgorithm::OfflineAlgorithm(const rl::TrainConfig& config, const OfflineConfig& common,
                                   int64_t obs_dim, int64_t act_dim, const torch::Device& device)
    : device_(device),
      obs_dim_(obs_dim),
      act_dim_(act_dim),
      common_(common),
      task_(config.task),
      dataset_(config.dataset),
      norm_(obs_dim) {
  norm_->to(device);
}

void OfflineAlgorithm::prepare_training() { set_data(load_transitions(dataset_)); }

void OfflineAlgorithm::set_data(const Transitions& d) {
  const std::string where = "dataset " + (dataset_.empty() ? d.info.dataset_id : dataset_);
  auto fail = [&](const std::string& what, const std::string& expected,
                  const std::string& actual) {
    throw DatasetError(where + ": " + what + ": expected " + expected + ", got " + actual);
  };
  if (d.info.task != task_) fail("task", task_ + " (the run's task)", d.info.task);
  if (d.info.obs_dim != obs_dim_)
    fail("obs_dim", std::to_string(obs_dim_) + " (the task's observation width)",
         std::to_string(d.info.obs_dim));
  if (d.info.act_dim != act_dim_)
    fail("act_dim", std::to_string(act_dim_) + " (the task's action width)",
         std::to_string(d.info.act_dim));
  const int64_t N = d.steps, D = obs_dim_, A = act_dim_;
  if (N < 1) fail("transitions", "at least 1", std::to_string(N));
  const int64_t rows = int64_t(d.observations.size()) / D;
  auto size = [&](const char* what, size_t got, int64_t want) {
    if (int64_t(got) != want) fail(std::string(what) + " values", std::to_string(want),
                                   std::to_string(got));
  };
  size("observations", d.observations.size(), rows * D);
  size("actions", d.actions.size(), N * A);
  size("rewards", d.rewards.size(), N);
  size("terminations", d.terminations.size(), N);
  size("obs_row", d.obs_row.size(), N);
  for (int64_t r : d.obs_row)
    if (r < 0 || r + 1 >= rows)
      fail("obs_row", "rows in [0, " + std::to_string(rows - 1) + ")", std::to_string(r));

  auto upload = [&](const void* p, std::vector<int64_t> shape, torch::ScalarType t) {
    return torch::from_blob(const_cast<void*>(p), shape, t).to(device_, t, false, true);
  };
  obs_rows_ = upload(d.observations.data(), {rows, D}, torch::kFloat);
  actions_ = upload(d.actions.data(), {N, A}, torch::kFloat);
  reward_ = upload(d.rewards.data(), {N}, torch::kFloat);
  not_done_ = 1 - upload(d.terminations.data(), {N}, torch::kUInt8).to(torch::kFloat);
  obs_row_ = upload(d.obs_row.data(), {N}, torch::kInt64);
  torch::NoGradGuard ng;
  if (common_.obs_norm) {
    auto [var, mean] = torch::var_mean(obs_rows_, {0}, /*unbiased=*/false);
    norm_->mean.copy_(mean);
    norm_->sd.copy_(var.sqrt().clamp_min(1e-3));
    // normalised once here, never per minibatch
    obs_rows_.sub_(norm_->mean).div_(norm_->sd);
  }
}

OfflineAlgorithm::Batch OfflineAlgorithm::sample() const {
  const auto i = torch::randint(actions_.size(0), {common_.batch_size},
                                torch::TensorOptions().dtype(torch::kInt64).device(device_));
  const auto row = obs_row_.index_select(0, i);
  return {obs_rows_.index_select(0, row), actions_.index_select(0, i),
          reward_.index_select(0, i), not_done_.index_select(0, i),
          obs_rows_.index_select(0, row + 1)};
}

std::vector<double> OfflineAlgorithm::update(const torch::Tensor&) {
  if (!actions_.defined())
    throw std::logic_error("offline algorithm: update() before set_data() (prepare_training)");
  const size_t M = metric_names().size();
  auto sums = torch::zeros({int64_t(M)},
                           torch::TensorOptions().dtype(torch::kFloat64).device(device_));
  std::vector<int64_t> counts(M, 0);
  for (int k = 0; k < common_.gradient_steps; ++k, ++steps_) {
    const auto m = train_step(sample(), steps_);
    torch::NoGradGuard ng;
    for (size_t j = 0; j < M; ++j)
      if (m[j].defined()) {
        sums[int64_t(j)].add_(m[j]);
        ++counts[j];
      }
  }
  const auto s = sums.to(torch::kCPU);
  std::vector<double> out(M, 0.0);
  for (size_t j = 0; j < M; ++j)
    if (counts[j]) out[j] = s[int64_t(j)].item<double>() / double(counts[j]);
  return out;
}

torch::Tensor OfflineAlgorithm::actor(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  return policy(common_.obs_norm ? norm_->forward(obs) : obs);
}

void OfflineAlgorithm::save(torch::serialize::OutputArchive& root) {
  rl::write_part(root, "obs_norm", *norm_);
  root.write("gradient_steps", torch::full({1}, steps_, torch::kInt64));
  save_parts(root);
}

void OfflineAlgorithm::load(torch::serialize::InputArchive& root, const std::string& path) {
  rl::read_checked(path, "does not fit this run's networks", [&] {
    rl::read_module(root, "obs_norm", *norm_, path, "this run's observation normaliser");
    torch::Tensor s;
    root.read("gradient_steps", s);
    steps_ = s.to(torch::kCPU).item<int64_t>();
    load_parts(root, path);
  });
}

void OfflineAlgorithm::load_actor(torch::serialize::InputArchive& root, const std::string& path) {
  rl::read_checked(path, "holds no actor", [&] {
    rl::read_module(root, "obs_norm", *norm_, path, "this run's observation normaliser");
    load_actor_parts(root, path);
  });
}

}  // namespace bidex::offline
