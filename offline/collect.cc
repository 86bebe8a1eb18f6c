#include "offline/collect.h"

#include <cmath>
#include <limits>
#include <optional>

#include <torch/torch.h>

#include "core/error.h"
#include "core/files.h"
#include "core/progress.h"
#include "offline/recorder.h"
#include "rl/checkpoint.h"
#include "rl/collector.h"
#include "rl/config.h"
#include "rl/metrics.h"
#include "rl/trainer.h"
#include "taskpack/pack.h"
#include "taskpack/warp_pack.h"

namespace bidex::offline {

namespace {

// mean of `v` over the `n` entries up to index `end` (inclusive), skipping NaN
double trailing_mean(const std::vector<double>& v, size_t end, size_t n) {
  double sum = 0;
  int k = 0;
  for (size_t i = end + 1 > n ? end + 1 - n : 0; i <= end; ++i)
    if (std::isfinite(v[i])) sum += v[i], ++k;
  return k ? sum / k : NAN;
}

}  // namespace

std::string medium_checkpoint(const std::string& run_dir) {
  const auto cks = rl::list_checkpoints(run_dir);
  if (cks.size() < 2)
    throw Error("run " + run_dir + " has " + std::to_string(cks.size()) +
                " checkpoint(s): a medium policy is chosen among several (train with a smaller "
                "train.save_interval and a larger train.keep_checkpoints, or pass --checkpoint)");
  const std::string name = run_dir + "/metrics.csv";
  std::vector<std::string> cols;
  std::vector<std::vector<double>> rows;
  rl::parse_metrics_csv(read_file(name), name, cols, rows);
  size_t c_update = cols.size(), c_return = cols.size();
  for (size_t i = 0; i < cols.size(); ++i) {
    if (cols[i] == "update") c_update = i;
    if (cols[i] == "return") c_return = i;
  }
  if (c_update == cols.size() || c_return == cols.size())
    throw Error(name + ": no update and return columns");
  std::vector<double> ret;
  std::vector<int64_t> upd;
  for (auto& r : rows) {
    upd.push_back(static_cast<int64_t>(r[c_update]));
    ret.push_back(r[c_return]);
  }
  auto score = [&](const std::string& ck) {
    const int64_t u = rl::read_checkpoint_meta(ck).update;
    for (size_t i = 0; i < upd.size(); ++i)
      if (upd[i] == u) return trailing_mean(ret, i, 10);
    return std::nan("");
  };
  const double target = 0.5 * score(cks.back());
  if (!std::isfinite(target))
    throw Error(name + ": no training return at the newest checkpoint " + cks.back());
  std::string best;
  double gap = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i + 1 < cks.size(); ++i) {
    const double s = score(cks[i]);
    if (std::isfinite(s) && std::abs(s - target) < gap) gap = std::abs(s - target), best = cks[i];
  }
  if (best.empty()) throw Error(name + ": no training return at any earlier checkpoint");
  return best;
}

DatasetInfo collect(const CollectOptions& o) {
  const bool random = o.quality == "random";
  if (!random && o.quality != "medium" && o.quality != "expert")
    throw ConfigError("--quality", "quality", "random, medium or expert (replay: bidex train "
                      "--record-replay; medium-expert: bidex collect --merge)", o.quality);
  if (o.steps < 1) throw ConfigError("--steps", "steps", "an integer >= 1", std::to_string(o.steps));
  if (o.slots < 1) throw ConfigError("--slots", "slots", "an integer >= 1", std::to_string(o.slots));
  if (!random && o.run_dir.empty())
    throw ConfigError("--run", "run", "the run whose policy collects a " + o.quality + " dataset",
                      "none");
  std::optional<rl::LoadedPolicy> expert;
  const std::string expert_run = o.expert_run.empty() ? o.run_dir : o.expert_run;
  if (!expert_run.empty()) expert.emplace(expert_run);
  rl::TrainConfig cfg;
  std::string checkpoint = o.checkpoint;
  if (!random && checkpoint.empty())
    checkpoint = o.quality == "medium" ? medium_checkpoint(o.run_dir) : "";
  std::optional<rl::LoadedPolicy> policy;
  if (!random) {
    policy.emplace(o.run_dir, checkpoint, o.device == "cpu" ? "cpu" : "auto");
    cfg = policy->config();
  } else if (expert) {
    cfg = expert->config();
  }
  if (!o.task.empty()) {
    if (!cfg.task.empty() && cfg.task != o.task)
      throw ConfigError("--task", "task", "the task of run " + (random ? expert_run : o.run_dir) +
                        " (" + cfg.task + ")", o.task);
    if (cfg.task.empty()) cfg.task = o.task;
  }
  if (cfg.task.empty())
    throw ConfigError(random ? "--task" : "--run", "task",
                      random ? "the task of a random dataset" : "a task run (datasets are of one "
                      "task)", cfg.suite.empty() ? "none" : "suite " + cfg.suite);
  if (expert && expert->config().task != cfg.task)
    throw ConfigError("--expert", "task", "a run of task " + cfg.task, expert->config().task);
  cfg.suite.clear();
  if (o.threads > 0) cfg.threads = o.threads;

  // the references first: a failure there costs nothing written
  const double ref_min =
      rl::evaluate_random(cfg, o.ref_episodes, o.seed + 1, cfg.threads).mean_return;
  const double ref_max =
      expert ? rl::evaluate(*expert, o.ref_episodes, o.seed + 2, cfg.threads).mean_return : NAN;

  const taskpack::PackSpec spec = rl::eval_pack(cfg, "train", o.slots, false);
  const std::string where = taskpack::choose_pack_device(o.device, spec);
  std::unique_ptr<taskpack::Pack> pack;
  torch::Device dev(torch::kCPU);
  if (where == "cuda") {
    pack = std::make_unique<taskpack::WarpPack>(spec,
                                                rl::run_warp_pack_options(cfg, o.seed, "cuda"));
    dev = torch::Device(torch::kCUDA, 0);
  } else {
    pack = std::make_unique<taskpack::TaskPack>(spec,
                                                rl::run_pack_options(cfg, o.seed, cfg.threads));
  }
  if (policy) policy->check_fits(*pack, "task " + cfg.task);

  DatasetInfo info = task_info(*pack, o.quality);
  info.ref_min_score = ref_min;
  info.ref_max_score = ref_max;
  info.policy = random ? "random" : policy->checkpoint();
  info.algorithm_name = random ? "random" : cfg.algo;
  info.seed = o.seed;
  info.command = o.command;
  DatasetWriter writer(o.out, info);
  std::vector<int64_t> all(pack->nslot());
  for (int64_t i = 0; i < pack->nslot(); ++i) all[i] = i;
  EpisodeRecorder rec(writer, all, pack->obs_dim(), pack->act_dim(), o.steps);
  auto collector = rl::make_collector(*pack, dev, true);
  torch::manual_seed(o.seed);
  std::optional<Progress> bar;
  if (o.progress) bar.emplace("collect " + info.dataset_id, o.steps, "steps");
  torch::Tensor obs = collector->reset();
  rec.begin(obs);
  const auto uniform = torch::TensorOptions().dtype(torch::kFloat32).device(dev);
  while (!rec.full()) {
    torch::Tensor a = random ? torch::rand({pack->nslot(), pack->act_dim()}, uniform) * 2 - 1
                             : policy->act(obs, o.sample);
    rl::Transition t = collector->step(a);
    rec.step(a, t);
    obs = t.obs;
    if (bar) {
      bar->set_status("episodes " + std::to_string(writer.episodes()));
      bar->update(std::min(writer.steps(), o.steps));
    }
  }
  if (bar) bar->finish();
  return writer.finish();
}

}  // namespace bidex::offline
