#include "rl/trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <optional>

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include "core/error.h"
#include "core/files.h"
#include "core/progress.h"
#include "rl/checkpoint.h"
#include "rl/metrics.h"
#include "rl/policy.h"
#include "rl/ppo.h"
#include "sim/tensor.h"
#include "tasks/env.h"
#include "tasks/registry.h"

namespace bidex::rl {

namespace {

volatile std::sig_atomic_t g_stop = 0;
extern "C" void on_stop_signal(int) { g_stop = 1; }

// SIGINT and SIGTERM set a flag for the length of a training run; the loop checks it between
// steps and writes a checkpoint before it returns.
class SignalScope {
 public:
  SignalScope() {
    g_stop = 0;
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    ::sigaction(SIGINT, &sa, &old_int_);
    ::sigaction(SIGTERM, &sa, &old_term_);
  }
  ~SignalScope() {
    ::sigaction(SIGINT, &old_int_, nullptr);
    ::sigaction(SIGTERM, &old_term_, nullptr);
  }

 private:
  struct sigaction old_int_, old_term_;
};

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

bool dir_is_empty_or_missing(const std::string& dir) {
  DIR* d = ::opendir(dir.c_str());
  if (!d) return true;
  bool empty = true;
  while (dirent* e = ::readdir(d))
    if (std::strcmp(e->d_name, ".") && std::strcmp(e->d_name, "..")) empty = false;
  ::closedir(d);
  return empty;
}

torch::Device pick_device(const TrainConfig& c, const std::string& name) {
  const bool cuda = torch::cuda::is_available();
  if (c.device == "cuda" && !cuda)
    throw ConfigError(name, "train.device", "cpu or auto (this LibTorch has no usable CUDA device)",
                      "cuda");
  if (c.device == "cpu" || !cuda) return torch::Device(torch::kCPU);
  return torch::Device(torch::kCUDA, 0);
}

std::vector<std::string> metric_columns(const tasks::TaskSpec& spec) {
  std::vector<std::string> cols = {"update", "steps", "wall_s", "fps", "sim_fps", "episodes",
                                   "return", "length", "success"};
  for (auto& t : spec.reward_terms) cols.push_back("term_" + t.name);
  for (const char* c : {"policy_loss", "value_loss", "entropy", "kl", "lr", "clip_fraction",
                        "action_std", "faults"})
    cols.push_back(c);
  return cols;
}

std::string checkpoint_path(const std::string& dir, int64_t update) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "/checkpoints/update_%08lld.ckpt", static_cast<long long>(update));
  return dir + buf;
}

std::string utc_now() {
  std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

// Everything one training process holds.
struct Session {
  std::string dir, yaml, name;
  TrainConfig cfg;
  torch::Device device{torch::kCPU};
  std::unique_ptr<tasks::TaskEnv> env;
  ActorCritic model{nullptr};
  std::unique_ptr<Ppo> ppo;
  int64_t update = 0, steps = 0;
  double wall = 0;  // seconds of training, summed over resumed sessions
  std::string last_checkpoint;

  void build(uint64_t env_seed) {
    device = pick_device(cfg, name);
    if (cfg.torch_threads > 0) torch::set_num_threads(cfg.torch_threads);
    torch::manual_seed(cfg.seed);
    tasks::EnvOptions eo;
    eo.nslot = cfg.slots;
    eo.threads = cfg.threads;
    eo.seed = env_seed;
    env = std::make_unique<tasks::TaskEnv>(tasks::make_task(cfg.task, cfg.task_config), eo);
    model = ActorCritic(env->obs_dim(), env->act_dim(), cfg.ppo);
    model->to(device);
    ppo = std::make_unique<Ppo>(model, cfg.ppo);
  }

  CheckpointMeta meta() const {
    CheckpointMeta m;
    m.task = cfg.task;
    m.task_version = env->spec().versioned_id();
    m.algo = cfg.algo;
    m.obs_dim = env->obs_dim();
    m.act_dim = env->act_dim();
    m.update = update;
    m.steps = steps;
    m.config_hash = config_hash(yaml);
    return m;
  }

  void save() {
    torch::serialize::OutputArchive root, net, opt;
    model->save(net);
    ppo->optimizer().save(opt);
    root.write("model", net);
    root.write("optimizer", opt);
    root.write("lr", torch::tensor({ppo->lr()}, torch::kFloat64));
    root.write("wall", torch::tensor({wall}, torch::kFloat64));
    const std::string path = checkpoint_path(dir, update);
    save_checkpoint(path, meta(), root);
    last_checkpoint = path;
    auto all = list_checkpoints(dir);
    for (size_t i = 0; i + cfg.keep_checkpoints < all.size(); ++i) ::unlink(all[i].c_str());
  }
};

// Loads a module's parameters and buffers from `archive` and checks that every tensor kept its
// shape (LibTorch's Module::load silently takes the archive's shapes).
void load_module_checked(torch::nn::Module& m, torch::serialize::InputArchive& archive,
                         const std::string& path, const std::string& what) {
  std::vector<std::pair<std::string, std::vector<int64_t>>> want;
  for (auto& p : m.named_parameters()) want.emplace_back(p.key(), p.value().sizes().vec());
  for (auto& b : m.named_buffers()) want.emplace_back(b.key(), b.value().sizes().vec());
  try {
    m.load(archive);
  } catch (const c10::Error& e) {
    std::string msg = e.what();
    throw Error("checkpoint " + path + ": does not fit " + what + " (" +
                msg.substr(0, msg.find('\n')) + ")");
  }
  auto params = m.named_parameters();
  auto buffers = m.named_buffers();
  for (auto& [name, sizes] : want) {
    const torch::Tensor* t = params.find(name);
    if (!t) t = buffers.find(name);
    if (!t || t->sizes().vec() != sizes)
      throw Error("checkpoint " + path + ": does not fit " + what + ": " + name + " has shape " +
                  (t ? c10::str(t->sizes()) : std::string("(missing)")) + ", expected " +
                  c10::str(c10::IntArrayRef(sizes)));
  }
}

// A checkpoint must belong to this task and these shapes.
void check_meta(const CheckpointMeta& m, const std::string& path, const std::string& task,
                int64_t obs_dim, int64_t act_dim, const std::string& where) {
  if (m.task != task || m.obs_dim != obs_dim || m.act_dim != act_dim)
    throw Error("checkpoint " + path + " was trained on task " + m.task + " (observations " +
                std::to_string(m.obs_dim) + ", actions " + std::to_string(m.act_dim) + "); " +
                where + " is task " + task + " (observations " + std::to_string(obs_dim) +
                ", actions " + std::to_string(act_dim) + ")");
}

void load_into(Session& s, const std::string& path) {
  CheckpointMeta m = read_checkpoint_meta(path);
  check_meta(m, path, s.cfg.task, s.env->obs_dim(), s.env->act_dim(), "run " + s.dir);
  torch::serialize::InputArchive root, net, opt;
  load_checkpoint(path, root, s.device);
  try {
    root.read("model", net);
    root.read("optimizer", opt);
    load_module_checked(*s.model, net, path, "this run's networks");
    s.ppo->optimizer().load(opt);
    torch::Tensor lr, wall;
    root.read("lr", lr);
    root.read("wall", wall);
    s.ppo->set_lr(lr.item<double>());
    s.wall = wall.item<double>();
  } catch (const c10::Error& e) {
    std::string msg = e.what();
    throw Error("checkpoint " + path + ": does not fit this run's networks (" +
                msg.substr(0, msg.find('\n')) + ")");
  }
  s.update = m.update;
  s.steps = m.steps;
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

TrainResult run_loop(Session& s, MetricsLog& log, const TrainOptions& opt) {
  SignalScope signals;
  auto& env = *s.env;
  const int N = env.nslot(), D = env.obs_dim(), A = env.act_dim();
  const int T = s.cfg.ppo.horizon;
  const int64_t total_updates = (s.cfg.steps + s.cfg.batch() - 1) / s.cfg.batch();
  const bool cuda = s.device.is_cuda();
  auto host_opts = torch::TensorOptions().dtype(torch::kFloat32).pinned_memory(cuda);
  // one transfer per step: [obs N*D | reward N | done N | bootstrap slot ids K | their final obs K*D]
  auto staging = torch::empty({int64_t(2) * N * D + 3 * N}, host_opts);
  float* st = staging.data_ptr<float>();
  Rollout ro(T, N, D, A, s.device);
  const double gamma = s.cfg.ppo.gamma;

  std::optional<Progress> bar;
  if (opt.progress) {
    bar.emplace("train " + s.cfg.task, s.cfg.steps, "steps");
    bar->set_baseline(std::min(s.steps, s.cfg.steps));
  }
  TrainResult res;
  res.run_dir = s.dir;
  res.last_return = NAN;
  res.last_success = NAN;
  double shown_return = NAN, shown_success = NAN;

  auto upload = [&](bool with_final, int* k_out) {
    std::memcpy(st, env.obs.data(), sizeof(float) * N * D);
    float* rew = st + int64_t(N) * D;
    float* done = rew + N;
    float* ids = done + N;
    int k = 0;
    for (int i = 0; i < N; ++i) {
      rew[i] = env.reward[i];
      done[i] = (env.terminated[i] || env.truncated[i]) ? 1.f : 0.f;
      if (with_final && env.truncated[i] && !env.fault[i]) ids[k++] = static_cast<float>(i);
    }
    float* fin = ids + k;
    for (int j = 0; j < k; ++j)
      std::memcpy(fin + int64_t(j) * D, env.final_obs.data() + int64_t(ids[j]) * D,
                  sizeof(float) * D);
    const int64_t used = int64_t(N) * D + 2 * N + k + int64_t(k) * D;
    *k_out = k;
    return cuda ? staging.narrow(0, 0, used).to(s.device, /*non_blocking=*/true)
                : staging.narrow(0, 0, used).clone();
  };

  env.reset();
  int k0 = 0;
  torch::Tensor obs = upload(false, &k0).narrow(0, 0, int64_t(N) * D).view({N, D});
  bool stopped = false;
  const double session_start = now();
  while (s.update < total_updates) {
    const double t_iter = now();
    double sim_s = 0;
    {
      torch::NoGradGuard ng;
      ro.log_std.copy_(s.model->log_std().detach());
      const auto std_dev = torch::exp(ro.log_std);
      for (int t = 0; t < T; ++t) {
        if (s.cfg.ppo.obs_norm) s.model->obs_norm()->update(obs);
        auto nobs = s.model->normalize_obs(obs);
        auto mu = s.model->mean(nobs);
        auto v = s.model->value(nobs);
        auto a = mu + std_dev * torch::randn_like(mu);
        ro.nobs[t].copy_(nobs);
        ro.actions[t].copy_(a);
        ro.mu[t].copy_(mu);
        ro.values[t].copy_(v);
        ro.logp[t].copy_(gaussian_log_prob(a, mu, ro.log_std));
        auto host_a = a.to(torch::kCPU).contiguous();
        const double t0 = now();
        env.step(host_a.data_ptr<float>());
        sim_s += now() - t0;
        int k = 0;
        auto dev = upload(true, &k);
        obs = dev.narrow(0, 0, int64_t(N) * D).view({N, D});
        auto rew = ro.rewards[t];
        rew.copy_(dev.narrow(0, int64_t(N) * D, N));
        ro.dones[t].copy_(dev.narrow(0, int64_t(N) * D + N, N));
        if (k > 0) {  // time limits: bootstrap from the critic's value of the final observation
          auto ids = dev.narrow(0, int64_t(N) * D + 2 * N, k).to(torch::kLong);
          auto fin = dev.narrow(0, int64_t(N) * D + 2 * N + k, int64_t(k) * D).view({k, D});
          rew.index_add_(0, ids, gamma * s.model->value(s.model->normalize_obs(fin)));
        }
        if (g_stop) break;
      }
    }
    if (g_stop) {  // the interrupted rollout is dropped; the last full update is kept
      stopped = true;
      break;
    }
    torch::Tensor last_value;
    {
      torch::NoGradGuard ng;
      last_value = s.model->value(s.model->normalize_obs(obs));
    }
    UpdateStats us = s.ppo->update(ro, last_value);
    s.update += 1;
    s.steps += s.cfg.batch();
    const double iter = now() - t_iter;
    s.wall += iter;
    auto es = env.take_stats();
    const double ep = static_cast<double>(es.episodes);
    std::vector<double> row = {double(s.update), double(s.steps), s.wall,
                               s.cfg.batch() / iter, s.cfg.batch() / std::max(sim_s, 1e-9), ep,
                               ep > 0 ? es.return_sum / ep : NAN,
                               ep > 0 ? es.length_sum / ep : NAN,
                               ep > 0 ? es.successes / ep : NAN};
    for (double t : es.term_sums) row.push_back(ep > 0 ? t / ep : NAN);
    double action_std = 0;
    {
      torch::NoGradGuard ng;
      action_std = torch::exp(s.model->log_std()).mean().item<double>();
    }
    for (double x : {us.policy_loss, us.value_loss, us.entropy, us.kl, us.lr, us.clip_fraction,
                     action_std, double(es.faults)})
      row.push_back(x);
    log.append(row);
    if (ep > 0) {
      shown_return = es.return_sum / ep;
      shown_success = es.successes / ep;
    }
    if (s.update % s.cfg.plot_interval == 0) log.plot(s.cfg.task + " (PPO)");
    if (s.update % s.cfg.save_interval == 0) s.save();
    if (bar) {
      bar->set_status("fps " + fmt("%.0f", s.cfg.batch() / iter) + " return " +
                     fmt("%.3g", shown_return) + " success " + fmt("%.2f", shown_success));
      bar->update(std::min(s.steps, s.cfg.steps));
    }
    const bool out_of_time = opt.time_limit_s > 0 && now() - session_start >= opt.time_limit_s;
    if (((opt.stop_after_updates > 0 && s.update >= opt.stop_after_updates) || out_of_time) &&
        s.update < total_updates) {
      stopped = true;
      break;
    }
  }
  if (bar) bar->finish();
  if (list_checkpoints(s.dir).empty() || s.last_checkpoint != checkpoint_path(s.dir, s.update))
    s.save();
  log.plot(s.cfg.task + " (PPO)");
  res.updates = s.update;
  res.steps = s.steps;
  res.interrupted = stopped;
  res.last_return = shown_return;
  res.last_success = shown_success;
  res.checkpoint = s.last_checkpoint;
  nlohmann::json summary = {{"task", s.cfg.task},
                            {"algo", s.cfg.algo},
                            {"updates", s.update},
                            {"steps", s.steps},
                            {"wall_s", s.wall},
                            {"finished", !stopped},
                            {"last_return", std::isfinite(shown_return) ? nlohmann::json(shown_return) : nlohmann::json()},
                            {"last_success", std::isfinite(shown_success) ? nlohmann::json(shown_success) : nlohmann::json()},
                            {"checkpoint", s.last_checkpoint},
                            {"time", utc_now()}};
  write_file_atomic(s.dir + "/summary.json", summary.dump(2) + "\n");
  return res;
}

void write_run_json(const Session& s, const TrainOptions& opt, bool resumed) {
  nlohmann::json j;
  const std::string path = s.dir + "/run.json";
  if (resumed) {
    try {
      j = nlohmann::json::parse(read_file(path));
    } catch (const std::exception&) {
      j = nlohmann::json::object();
    }
  }
  if (!resumed) {
    j["task"] = s.cfg.task;
    j["task_version"] = s.env->spec().versioned_id();
    j["algo"] = s.cfg.algo;
    j["seed"] = s.cfg.seed;
    j["config_hash"] = config_hash(s.yaml);
    j["started"] = utc_now();
    j["sessions"] = nlohmann::json::array();
  }
  j["sessions"].push_back({{"time", utc_now()},
                           {"command", opt.command},
                           {"device", s.device.str()},
                           {"from_update", s.update},
                           {"threads", s.env->threads()}});
  write_file_atomic(path, j.dump(2) + "\n");
}

}  // namespace

std::string default_run_dir(const TrainConfig& c) {
  std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", std::localtime(&t));
  return "runs/" + c.task + "-" + c.algo + "-" + buf + "-s" + std::to_string(c.seed);
}

TrainResult train_new(const std::string& resolved_yaml, const std::string& run_dir,
                      const TrainOptions& options) {
  Session s;
  s.dir = run_dir;
  s.yaml = resolved_yaml;
  s.name = run_dir + "/config.yaml";
  s.cfg = parse_train_config(resolved_yaml, "the resolved configuration");
  if (!dir_is_empty_or_missing(run_dir))
    throw Error("run folder " + run_dir + " exists and is not empty: continue it with --resume " +
                run_dir + ", or choose another --run");
  s.build(s.cfg.seed);
  write_file_atomic(run_dir + "/config.yaml", resolved_yaml);
  write_run_json(s, options, false);
  MetricsLog log(run_dir, metric_columns(s.env->spec()));
  return run_loop(s, log, options);
}

TrainResult train_resume(const std::string& run_dir, const TrainOptions& options) {
  Session s;
  s.dir = run_dir;
  s.name = run_dir + "/config.yaml";
  s.yaml = read_file(s.name);
  s.cfg = parse_train_config(s.yaml, s.name);
  auto cks = list_checkpoints(run_dir);
  if (cks.empty())
    throw Error("run " + run_dir + " has no checkpoint to resume from (" + run_dir +
                "/checkpoints/update_*.ckpt)");
  const CheckpointMeta m = read_checkpoint_meta(cks.back());
  // the environment restarts its episodes: a new seed per resumed session, so that they differ
  s.build(s.cfg.seed + 1000003ull * static_cast<uint64_t>(m.update));
  load_into(s, cks.back());
  s.last_checkpoint = cks.back();
  write_run_json(s, options, true);
  MetricsLog log = MetricsLog::resume(run_dir, metric_columns(s.env->spec()), s.update);
  return run_loop(s, log, options);
}

struct LoadedPolicy::Impl {
  TrainConfig cfg;
  std::string checkpoint;
  CheckpointMeta meta;
  ActorCritic model{nullptr};
};

LoadedPolicy::LoadedPolicy(const std::string& run_dir, const std::string& checkpoint)
    : impl_(std::make_unique<Impl>()) {
  const std::string name = run_dir + "/config.yaml";
  impl_->cfg = parse_train_config(read_file(name), name);
  std::string path = checkpoint;
  if (path.empty()) {
    auto cks = list_checkpoints(run_dir);
    if (cks.empty()) throw Error("run " + run_dir + " has no checkpoint (" + run_dir +
                                 "/checkpoints/update_*.ckpt)");
    path = cks.back();
  }
  impl_->checkpoint = path;
  const auto& spec = tasks::find_task(impl_->cfg.task).spec();
  const CheckpointMeta m = read_checkpoint_meta(path);
  check_meta(m, path, impl_->cfg.task, spec.obs.dim(), spec.act.dim(), "run " + run_dir);
  impl_->meta = m;
  impl_->model = ActorCritic(m.obs_dim, m.act_dim, impl_->cfg.ppo);
  torch::serialize::InputArchive root, net;
  load_checkpoint(path, root, torch::Device(torch::kCPU));
  try {
    root.read("model", net);
  } catch (const c10::Error& e) {
    std::string msg = e.what();
    throw Error("checkpoint " + path + ": holds no networks (" + msg.substr(0, msg.find('\n')) +
                ")");
  }
  load_module_checked(*impl_->model, net, path, "the networks of " + name);
  impl_->model->eval();
}

LoadedPolicy::~LoadedPolicy() = default;
const TrainConfig& LoadedPolicy::config() const { return impl_->cfg; }
const std::string& LoadedPolicy::checkpoint() const { return impl_->checkpoint; }
int64_t LoadedPolicy::obs_dim() const { return impl_->meta.obs_dim; }
int64_t LoadedPolicy::act_dim() const { return impl_->meta.act_dim; }
int64_t LoadedPolicy::update() const { return impl_->meta.update; }

void LoadedPolicy::act(const float* obs, int n, float* actions) {
  torch::NoGradGuard ng;
  auto o = torch::from_blob(const_cast<float*>(obs), {n, impl_->meta.obs_dim}, torch::kFloat32);
  auto a = impl_->model->mean(impl_->model->normalize_obs(o)).clamp(-1.0, 1.0).contiguous();
  std::memcpy(actions, a.data_ptr<float>(), sizeof(float) * n * impl_->meta.act_dim);
}

EvalResult evaluate(LoadedPolicy& policy, int episodes, uint64_t seed, int threads) {
  const auto& c = policy.config();
  tasks::EnvOptions eo;
  eo.nslot = episodes;
  eo.threads = threads;
  eo.seed = seed;
  tasks::TaskEnv env(tasks::make_task(c.task, c.task_config), eo);
  env.reset();
  std::vector<float> act(size_t(episodes) * env.act_dim());
  std::vector<double> ret(episodes, 0.0), done_ret(episodes, 0.0);
  std::vector<int> len(episodes, 0), done_len(episodes, 0);
  std::vector<uint8_t> finished(episodes, 0), succ(episodes, 0);
  int left = episodes;
  EvalResult r;
  while (left > 0) {
    policy.act(env.obs.data(), episodes, act.data());
    env.step(act);
    for (int s = 0; s < episodes; ++s) {
      if (env.fault[s]) r.faults += 1;
      if (finished[s]) continue;
      ret[s] += env.reward[s];
      len[s] += 1;
      if (env.terminated[s] || env.truncated[s]) {
        finished[s] = 1;
        done_ret[s] = ret[s];
        done_len[s] = len[s];
        succ[s] = env.success[s];
        --left;
      }
    }
  }
  r.episodes = episodes;
  double sum = 0, sq = 0, ls = 0, ss = 0;
  for (int s = 0; s < episodes; ++s) {
    sum += done_ret[s];
    sq += done_ret[s] * done_ret[s];
    ls += done_len[s];
    ss += succ[s];
  }
  r.mean_return = sum / episodes;
  r.std_return = std::sqrt(std::max(0.0, sq / episodes - r.mean_return * r.mean_return));
  r.mean_length = ls / episodes;
  r.success_rate = ss / episodes;
  return r;
}

}  // namespace bidex::rl
