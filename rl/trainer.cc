#include "rl/trainer.h"

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <optional>
#include <random>

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include "core/clock.h"
#include "core/error.h"
#include "core/files.h"
#include "core/idle_threads.h"
#include "core/progress.h"
#include "rl/algorithm.h"
#include "rl/checkpoint.h"
#include "rl/collector.h"
#include "rl/metrics.h"
#include "rl/recent_scores.h"
#include "rl/stage_timer.h"
#include "sim/batch.h"
#include "sim/tensor.h"
#include "sim/warp_backend.h"
#include "taskpack/pack.h"
#include "taskpack/suite.h"
#include "taskpack/warp_pack.h"
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

// The pack a run trains on: its task alone (one entry, plain observations), or a split of its
// suite (training: the train split) with `slots` spread over the entries.
taskpack::PackSpec run_pack(const TrainConfig& c, int slots, const std::string& split = "train") {
  if (!c.suite.empty()) return taskpack::suite_pack(taskpack::load_suite(c.suite), split, slots);
  taskpack::PackSpec p;
  p.name = c.task;
  p.mode = taskpack::PackMode::kPlain;
  taskpack::PackEntry e;
  e.task = c.task;
  e.label = c.task;
  e.config = c.task_config;
  e.slots = slots;
  p.entries.push_back(e);
  return p;
}

// Meta-RL trains on a meta suite's train split and is evaluated on its held-out test split; a
// multi-task suite has none (its test split is its train split).
void check_meta_suite(const taskpack::Suite& suite, const std::string& where) {
  if (!suite.held_out())
    throw ConfigError(where, "suite",
                      "a meta suite with a held-out test split (" +
                          taskpack::known_suites_text(true) + ")",
                      suite.id + " (no held-out test split: " +
                          (suite.mode == taskpack::PackMode::kMeta
                               ? "its test split is its train split"
                               : "a multi-task suite tests on its train tasks") +
                          ")");
}

// Columns of metrics.csv: the run's own (steps, rates, the physics' load per slot-step, episodes,
// returns; a task run has one column per reward term, a suite run the return and success rate of
// each task and the mean of the scaled returns, what the algorithm optimises), the algorithm's
// metrics, then faults.
std::vector<std::string> metric_columns(const taskpack::Pack& pack, const Algorithm& algo) {
  std::vector<std::string> cols = {"update", "steps", "wall_s", "fps", "sim_fps", "efc_rows",
                                   "solver_iters", "episodes", "return", "length", "success"};
  if (pack.ngroups() == 1) {
    for (auto& t : pack.task_spec(0).reward_terms) cols.push_back("term_" + t.name);
    if (pack.curriculum(0)) cols.push_back("curriculum_level");  // the slots' mean level
  } else {
    cols.push_back("scaled_return");
    for (int g = 0; g < pack.ngroups(); ++g) cols.push_back("return_" + pack.label(g));
    for (int g = 0; g < pack.ngroups(); ++g) cols.push_back("success_" + pack.label(g));
  }
  for (auto& c : algo.metric_names()) cols.push_back(c);
  cols.push_back("faults");
  return cols;
}

// A resumed task run under a curriculum: the slots' levels live in the environment, not the
// checkpoint, so each slot restarts from the mean level that the resumed log (its rows up to the
// checkpoint) logged last, from the slot's next episode, not from the curriculum's start.
void restore_levels(taskpack::Pack& env, const MetricsLog& log) {
  if (env.ngroups() != 1 || !env.curriculum(0)) return;
  const std::vector<double> levels = log.column("curriculum_level");
  for (auto v = levels.rbegin(); v != levels.rend(); ++v)
    if (std::isfinite(*v)) {
      env.set_levels(0, *v);
      return;
    }
}

std::string checkpoint_path(const std::string& dir, int64_t update) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "/checkpoints/update_%08lld.ckpt", static_cast<long long>(update));
  return dir + buf;
}

// The versioned id of what a run trains on: the task's (catch_underarm-v1), or for a suite its
// id and the versioned ids of its entries.
std::string target_version(const taskpack::Pack& pack) {
  if (pack.ngroups() == 1 && pack.spec().mode == taskpack::PackMode::kPlain)
    return pack.task_spec(0).versioned_id();
  std::string v = pack.spec().name + "[";
  for (int g = 0; g < pack.ngroups(); ++g)
    v.append(g ? "," : "").append(pack.task_spec(g).versioned_id());
  return v + "]";
}

// Everything one training process holds.
struct Session {
  std::string dir, yaml, name;
  TrainConfig cfg;
  torch::Device device{torch::kCPU};
  std::string sim_device, sim_why;  // where the pack steps, and why there
  std::unique_ptr<taskpack::Pack> env;
  std::unique_ptr<Algorithm> algo;
  int64_t update = 0, steps = 0;
  double wall = 0;  // seconds of training, summed over resumed sessions
  std::string last_checkpoint;

  void build(uint64_t env_seed, const std::string& requested_sim_device, bool new_run) {
    device = pick_device(cfg, name);
    if (cfg.torch_threads > 0) torch::set_num_threads(cfg.torch_threads);
    if (device.is_cuda())
      at::globalContext().setFloat32MatmulPrecision(cfg.tf32 ? "high" : "highest");
    torch::manual_seed(cfg.seed);
    if (find_algorithm(cfg.algo).meta) check_meta_suite(taskpack::load_suite(cfg.suite), name);
    const taskpack::PackSpec spec = run_pack(cfg, cfg.slots);
    sim_device = choose_sim_device(requested_sim_device, spec, &sim_why);
    if (sim_device == "cpu") {
      env = std::make_unique<taskpack::TaskPack>(spec,
                                                 run_pack_options(cfg, env_seed, cfg.threads));
    } else {
      env = std::make_unique<taskpack::WarpPack>(
          spec, run_warp_pack_options(cfg, env_seed, sim_device == "warp-cpu" ? "cpu" : "cuda"));
      if (sim_device == "warp-cpu") device = torch::Device(torch::kCPU);
    }
    // a new run's config.yaml is written after this, and says what ran; a resumed run's is kept
    settle_auto(cfg, device.is_cuda(), new_run ? &yaml : nullptr);
    algo = make_algorithm(cfg.algo, cfg, env->obs_dim(), env->act_dim(), env->nslot(), device);
    int ntasks = 0;
    const std::vector<int> tasks = env->slot_tasks(&ntasks);
    algo->set_slot_tasks(tasks, ntasks);
  }

  // The simulation's device: cpu, cuda or warp-cpu as asked (cuda needs the learner on the GPU
  // too), or for auto cuda when the pack runs on the GPU backend and LibTorch has CUDA.
  std::string choose_sim_device(const std::string& requested, const taskpack::PackSpec& spec,
                                std::string* why) const {
    if (requested == "warp-cpu") {
      *why = "as asked (the GPU path's code on Warp's CPU device)";
      return requested;
    }
    const std::string d = taskpack::choose_pack_device(requested, spec, why);
    if (d != "cuda") return d;
    const bool asked = requested == "cuda";
    if (asked) sim::require_gpu();  // the machine's lack first, then the learner's
    if (cfg.device == "cpu") {
      if (asked)
        throw ConfigError(name, "train.device",
                          "cuda or auto: with --device cuda the simulation's rows are read in "
                          "place on the GPU, so the learner must be there too",
                          "cpu");
      *why = "train.device is cpu";
      return "cpu";
    }
    if (!device.is_cuda()) {
      if (asked)
        throw DeviceError("--device cuda: this LibTorch has no CUDA, and the learner must be on "
                          "the GPU with the simulation; build against a CUDA LibTorch "
                          "(scripts/offline-build.sh, README \"With a GPU\") or use --device cpu");
      *why = "this LibTorch has no CUDA";
      return "cpu";
    }
    return d;
  }

  // what one update adds to `steps`: slot-steps, or an offline algorithm's gradient steps
  int64_t batch() const { return algo->steps_counted(env->nslot()); }
  // A dataset run's pack only evaluates: each update starts every slot afresh and runs one
  // episode length with the policy as it stands (TrainsOn::kDataset).
  bool offline() const { return find_algorithm(cfg.algo).trains_on == TrainsOn::kDataset; }

  CheckpointMeta meta() const {
    CheckpointMeta m;
    m.task = cfg.target();
    m.task_version = target_version(*env);
    m.algo = cfg.algo;
    m.obs_dim = env->obs_dim();
    m.act_dim = env->act_dim();
    m.update = update;
    m.steps = steps;
    m.config_hash = config_hash(yaml);
    return m;
  }

  void save() {
    torch::serialize::OutputArchive root;
    algo->save(root);
    root.write("wall", torch::tensor({wall}, torch::kFloat64));
    const std::string path = checkpoint_path(dir, update);
    save_checkpoint(path, meta(), root);
    last_checkpoint = path;
    auto all = list_checkpoints(dir);
    for (size_t i = 0; i + cfg.keep_checkpoints < all.size(); ++i) ::unlink(all[i].c_str());
  }
};

// "task hand_over" or "suite MT4".
std::string kind_of(const std::string& target) {
  for (auto* list : {&tasks::task_registry(), &tasks::variant_registry()})
    for (auto& e : *list)
      if (e.spec().id == target) return "task " + target;
  return "suite " + target;
}

// A checkpoint must belong to this task and these shapes.
void check_meta(const CheckpointMeta& m, const std::string& path, const std::string& task,
                int64_t obs_dim, int64_t act_dim, const std::string& where) {
  if (m.task != task || (obs_dim > 0 && m.obs_dim != obs_dim) ||
      (act_dim > 0 && m.act_dim != act_dim))
    throw Error("checkpoint " + path + " was trained on " + kind_of(m.task) + " (observations " +
                std::to_string(m.obs_dim) + ", actions " + std::to_string(m.act_dim) + "); " +
                where + " is " + kind_of(task) +
                (obs_dim > 0 ? " (observations " + std::to_string(obs_dim) + ", actions " +
                                   std::to_string(act_dim) + ")"
                             : std::string()));
}

// A checkpoint must hold the state of this run's algorithm.
void check_algo(const CheckpointMeta& m, const std::string& path, const std::string& algo,
                const std::string& where) {
  if (m.algo != algo)
    throw Error("checkpoint " + path + " holds the state of algorithm " + m.algo + "; " + where +
                " trains with " + algo);
}

void load_into(Session& s, const std::string& path) {
  CheckpointMeta m = read_checkpoint_meta(path);
  check_meta(m, path, s.cfg.target(), s.env->obs_dim(), s.env->act_dim(), "run " + s.dir);
  check_algo(m, path, s.cfg.algo, "run " + s.dir);
  torch::serialize::InputArchive root;
  load_checkpoint(path, root, s.device);
  s.algo->load(root, path);
  try {
    torch::Tensor wall;
    root.read("wall", wall);
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

// Where a session's time went, per update (--profile).
struct StepTimes {
  int64_t updates = 0, slot_steps = 0;
  double rollout = 0, sim = 0, update = 0;
  StageTimer policy;  // the rollout's acting ("act") and the algorithm's storing ("store")
  void add(double rollout_s, double sim_s, double update_s, int64_t batch) {
    updates += 1;
    slot_steps += batch;
    rollout += rollout_s;
    sim += sim_s;
    update += update_s;
  }
};

// <run>/profile.json: the split of a session's training time. The simulation is the pack's
// steps; on the GPU they divide into physics and task kernels (apply, evaluate, reset, observe,
// rows); the policy is the rest of the rollout (acting, storing, copies); the update is the
// learning step.
void write_profile(const Session& s, const Algorithm& algo, const StepTimes& t) {
  const tasks::StageProfile p = s.env->profile();
  const double total = t.rollout + t.update;
  auto policy = t.policy.totals();
  nlohmann::json sec = {{"simulation", t.sim}, {"policy", t.rollout - t.sim}, {"update", t.update},
                        {"act", policy["act"]}, {"store", policy["store"]}};
  if (s.sim_device != "cpu") {
    sec["task_kernels"] = p.actions + p.task;
    sec["physics"] = p.wall - p.actions - p.task;
  }
  nlohmann::json j = {{"task", s.cfg.target()},
                      {"algo", s.cfg.algo},
                      {"sim_device", s.sim_device},
                      {"learner_device", s.device.str()},
                      {"slots", s.env->nslot()},
                      {"updates", t.updates},
                      {"slot_steps", t.slot_steps},
                      {"wall_s", total},
                      {"slot_steps_per_s", total > 0 ? t.slot_steps / total : 0.0},
                      {"seconds", sec},
                      {"time", utc_now()}};
  // the update's stages, where the algorithm splits it (rl/stage_timer.h)
  const auto learner = algo.learner_profile();
  if (!learner.empty()) j["learner"] = learner;
  write_file_atomic(s.dir + "/profile.json", j.dump(2) + "\n");
}

// An update whose metrics are not all finite has stepped the learner's parameters with a
// non-finite loss or gradient: the run stops there without saving them, so its checkpoints stay
// as they were. Returns the message (empty when every metric is finite).
std::string non_finite_metric(const Session& s, const Algorithm& algo,
                              const std::vector<double>& metrics) {
  const std::vector<std::string>& names = algo.metric_names();
  for (size_t k = 0; k < metrics.size(); ++k) {
    if (std::isfinite(metrics[k])) continue;
    const std::string name = k < names.size() ? names[k] : "#" + std::to_string(k);
    const std::string keep =
        s.last_checkpoint.empty()
            ? "no checkpoint was written before it; start the run again (a lower learning rate "
              "or a smaller gradient clip may help)"
            : "the newest checkpoint, " + s.last_checkpoint +
                  ", is untouched: bidex train --resume " + s.dir + " goes on from it";
    return "train " + s.dir + ": update " + std::to_string(s.update + 1) +
           " diverged: its metric " + name + " is " + fmt("%g", metrics[k]) +
           " (expected a finite number); the parameters it stepped are not saved, and " + keep;
  }
  return "";
}

TrainResult run_loop(Session& s, MetricsLog& log, const TrainOptions& opt) {
  SignalScope signals;
  auto& env = *s.env;
  Algorithm& algo = *s.algo;
  const bool offline = s.offline();
  const int T = offline ? env.task_spec(0).episode_length : algo.steps_per_update();
  const int64_t batch = s.batch();
  const int64_t total_updates = (s.cfg.steps + batch - 1) / batch;
  std::unique_ptr<StepRecorder> recorder;
  if (opt.recorder) recorder = opt.recorder(s.cfg, env);
  std::unique_ptr<Collector> collector_ptr = make_collector(env, s.device, recorder != nullptr);
  Collector& collector = *collector_ptr;

  std::optional<Progress> bar;
  if (opt.progress) {
    bar.emplace("train " + s.cfg.target(), s.cfg.steps, "steps");
    bar->set_baseline(std::min(s.steps, s.cfg.steps));
  }
  TrainResult res;
  res.run_dir = s.dir;
  // an offline run's score is its last policy's evaluation; a collecting run's, its recent episodes
  RecentScores recent(offline ? 1 : 10);
  const std::string title = s.cfg.target() + " (" + find_algorithm(s.cfg.algo).title + ")";
  res.last_return = NAN;
  res.last_success = NAN;
  double shown_return = NAN, shown_success = NAN;

  torch::Tensor obs = collector.reset();
  if (recorder) recorder->begin(obs);
  bool stopped = false, first = true;
  std::string diverged;  // why the last update's learner state is not finite (then not saved)
  // when to stop as Ctrl-C would (0: never): the earlier of this session's training time limit
  // and the command's wall-clock deadline (bidex train --time-limit, --wall-limit)
  double stop_at = opt.stop_at_monotonic_s;
  if (opt.time_limit_s > 0) {
    const double t = monotonic_seconds() + opt.time_limit_s;
    stop_at = stop_at > 0 ? std::min(stop_at, t) : t;
  }
  StepTimes times;
  if (opt.profile) {
    env.set_profile(true);
    algo.enable_profile();
    times.policy.enable(s.device);
  }
  while (s.update < total_updates) {
    const double t_iter = monotonic_seconds();
    if (offline && !first) {
      env.take_stats();  // nothing of the last policy's episodes carries over
      obs = collector.reset();
    }
    first = false;
    for (int t = 0; t < T && !g_stop; ++t) {
      times.policy.start();
      const torch::Tensor actions = algo.act(obs);
      times.policy.mark("act");
      Transition tr = collector.step(actions);
      times.policy.start();
      algo.observe(tr);
      times.policy.mark("store");
      if (recorder && !recorder->step(actions, tr)) {
        recorder->finish();
        recorder.reset();
        collector.stop_recording();
      }
      obs = tr.obs;
    }
    const double sim_s = collector.take_sim_seconds();
    if (g_stop) {  // the interrupted rollout is dropped; the last full update is kept
      stopped = true;
      break;
    }
    const double t_update = monotonic_seconds();
    const std::vector<double> algo_metrics = algo.update(obs);
    diverged = non_finite_metric(s, algo, algo_metrics);
    if (!diverged.empty()) break;
    if (opt.profile) {
      if (s.device.is_cuda()) torch::cuda::synchronize(s.device.index());
      times.add(t_update - t_iter, sim_s, monotonic_seconds() - t_update, batch);
    }
    s.update += 1;
    s.steps += batch;
    const double iter = monotonic_seconds() - t_iter;
    s.wall += iter;
    const std::vector<tasks::EpisodeStats> per = env.take_stats();
    recent.add(per);
    // return, length and success: the mean over the entries whose episodes ended (one entry:
    // the mean over episodes); per-entry columns for a suite
    double ep = 0, ret = 0, len = 0, succ = 0, scaled = 0;
    int64_t faults = 0;
    int with = 0;
    for (int g = 0; g < env.ngroups(); ++g) {
      const auto& es = per[g];
      faults += es.faults;
      ep += static_cast<double>(es.episodes);
      if (es.episodes == 0) continue;
      const double n = static_cast<double>(es.episodes);
      ret += es.return_sum / n;
      len += es.length_sum / n;
      succ += es.successes / n;
      scaled += env.entry(g).reward_scale * es.return_sum / n;
      with += 1;
    }
    const double mean_return = with ? ret / with : NAN, mean_success = with ? succ / with : NAN;
    const taskpack::Pack::PhysicsLoad load = env.take_load();
    std::vector<double> row = {double(s.update), double(s.steps), s.wall,
                               batch / iter, batch / std::max(sim_s, 1e-9), load.rows,
                               load.iterations, ep, mean_return, with ? len / with : NAN,
                               mean_success};
    if (env.ngroups() == 1) {
      for (double t : per[0].term_sums) row.push_back(ep > 0 ? t / ep : NAN);
      if (env.curriculum(0))
        row.push_back(per[0].levels ? per[0].level_sum / per[0].levels : NAN);
    } else {
      row.push_back(with ? scaled / with : NAN);
      for (auto& es : per) row.push_back(es.episodes ? es.return_sum / es.episodes : NAN);
      for (auto& es : per)
        row.push_back(es.episodes ? static_cast<double>(es.successes) / es.episodes : NAN);
    }
    row.insert(row.end(), algo_metrics.begin(), algo_metrics.end());
    row.push_back(double(faults));
    log.append(row);
    if (with > 0) {
      shown_return = mean_return;
      shown_success = mean_success;
    }
    if (s.update % s.cfg.plot_interval == 0) log.plot(title);
    if (s.update % s.cfg.save_interval == 0) s.save();
    if (bar) {
      bar->set_status("fps " + fmt("%.0f", batch / iter) + " return " +
                     fmt("%.3g", shown_return) + " success " + fmt("%.2f", shown_success));
      bar->update(std::min(s.steps, s.cfg.steps));
    }
    const bool out_of_time = stop_at > 0 && monotonic_seconds() >= stop_at;
    if (((opt.stop_after_updates > 0 && s.update >= opt.stop_after_updates) || out_of_time) &&
        s.update < total_updates) {
      stopped = true;
      break;
    }
  }
  if (bar) bar->finish();
  if (recorder) recorder->finish();  // an interrupted run keeps the episodes it recorded
  if (!diverged.empty()) {
    log.plot(title);
    throw Error(diverged);
  }
  if (list_checkpoints(s.dir).empty() || s.last_checkpoint != checkpoint_path(s.dir, s.update))
    s.save();
  log.plot(title);
  for (int g = 0; g < env.ngroups(); ++g)
    res.scores.push_back(recent.score(g, env.label(g), env.entry(g).task));
  res.updates = s.update;
  res.steps = s.steps;
  res.interrupted = stopped;
  res.last_return = shown_return;
  res.last_success = shown_success;
  res.checkpoint = s.last_checkpoint;
  res.sim_device = s.sim_device;
  // the GPU's room per entry: the most constraint rows a world needed against gpu.njmax
  nlohmann::json rows = nlohmann::json::array();
  if (auto* gpu = dynamic_cast<taskpack::WarpPack*>(s.env.get())) {
    res.room_advice = gpu->room_advice();
    const auto r = gpu->rows();
    for (int g = 0; g < gpu->ngroups(); ++g)
      rows.push_back({{"label", gpu->label(g)}, {"rows_needed", r[g].needed}, {"njmax", r[g].room}});
  }
  nlohmann::json scores = nlohmann::json::array();
  auto or_null = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  for (auto& e : res.scores)
    scores.push_back({{"label", e.label}, {"task", e.task}, {"episodes", e.episodes},
                      {"mean_return", or_null(e.mean_return)}, {"success", or_null(e.success)}});
  nlohmann::json summary = {{s.cfg.suite.empty() ? "task" : "suite", s.cfg.target()},
                            {"algo", s.cfg.algo},
                            {"sim_device", s.sim_device},
                            {"room_advice", res.room_advice},
                            {"gpu_rows", rows},
                            {"updates", s.update},
                            {"steps", s.steps},
                            {"wall_s", s.wall},
                            {"finished", !stopped},
                            {"last_return", std::isfinite(shown_return) ? nlohmann::json(shown_return) : nlohmann::json()},
                            {"last_success", std::isfinite(shown_success) ? nlohmann::json(shown_success) : nlohmann::json()},
                            {"checkpoint", s.last_checkpoint},
                            {"scores_last_10_updates", scores},
                            {"time", utc_now()}};
  write_file_atomic(s.dir + "/summary.json", summary.dump(2) + "\n");
  if (opt.profile) write_profile(s, algo, times);
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
    j[s.cfg.suite.empty() ? "task" : "suite"] = s.cfg.target();
    j["task_version"] = target_version(*s.env);
    j["algo"] = s.cfg.algo;
    j["seed"] = s.cfg.seed;
    j["config_hash"] = config_hash(s.yaml);
    j["started"] = utc_now();
    j["sessions"] = nlohmann::json::array();
  }
  // how idle threads waited (core/idle_threads.h): CPU training speed depends on it
  nlohmann::json idle = nlohmann::json::object();
  for (const auto& t : kIdleThreadSettings) {
    const char* v = std::getenv(t.name);
    idle[t.name] = v ? nlohmann::json(v) : nlohmann::json();
  }
  j["sessions"].push_back({{"time", utc_now()},
                           {"command", opt.command},
                           {"device", s.device.str()},
                           {"sim_device", s.sim_device},
                           {"sim_device_reason", s.sim_why},
                           {"from_update", s.update},
                           {"threads", s.env->threads()},
                           {"idle_threads", idle}});
  write_file_atomic(path, j.dump(2) + "\n");
}

}  // namespace

taskpack::PackSpec eval_pack(const TrainConfig& c, const std::string& split, int per_task,
                             bool per_goal) {
  size_t entries = 1;
  if (!c.suite.empty()) {
    const taskpack::Suite su = taskpack::load_suite(c.suite);
    entries = std::max(su.train.size(), su.test.size());
  }
  taskpack::PackSpec ps = run_pack(c, per_task * static_cast<int>(entries), split);
  for (auto& e : ps.entries)
    e.slots = per_task * (per_goal ? std::max<int>(1, static_cast<int>(e.goals.size())) : 1);
  return ps;
}

taskpack::PackOptions run_pack_options(const TrainConfig& c, uint64_t seed, int threads) {
  taskpack::PackOptions o;
  o.threads = threads;
  o.seed = seed;
  o.physics_file = c.physics;
  return o;
}

taskpack::WarpPackOptions run_warp_pack_options(const TrainConfig& c, uint64_t seed,
                                                const std::string& device) {
  taskpack::WarpPackOptions o;
  o.seed = seed;
  o.device = device;
  o.physics_file = c.physics;
  return o;
}

std::string default_run_dir(const TrainConfig& c) {
  std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", std::localtime(&t));
  // a suite given as a file: its name without folder and extension
  std::string name = c.target();
  if (const size_t slash = name.rfind('/'); slash != std::string::npos) name = name.substr(slash + 1);
  if (const size_t dot = name.rfind('.'); dot != std::string::npos && dot > 0) name.resize(dot);
  return "runs/" + name + "-" + c.algo + "-" + buf + "-s" + std::to_string(c.seed);
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
  s.build(s.cfg.seed, options.device, true);
  s.algo->prepare_training();  // an offline algorithm's dataset, checked before anything is written
  write_file_atomic(run_dir + "/config.yaml", s.yaml);
  write_run_json(s, options, false);
  if (options.on_start) options.on_start(s.cfg, run_dir);
  MetricsLog log(run_dir, metric_columns(*s.env, *s.algo));
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
  s.build(s.cfg.seed + 1000003ull * static_cast<uint64_t>(m.update), options.device, false);
  s.algo->prepare_training();
  load_into(s, cks.back());
  s.last_checkpoint = cks.back();
  write_run_json(s, options, true);
  if (options.on_start) options.on_start(s.cfg, run_dir);
  MetricsLog log = MetricsLog::resume(run_dir, metric_columns(*s.env, *s.algo), s.update);
  restore_levels(*s.env, log);
  return run_loop(s, log, options);
}

struct LoadedPolicy::Impl {
  TrainConfig cfg;
  std::string checkpoint;
  CheckpointMeta meta;
  std::unique_ptr<Algorithm> algo;
  torch::Device device{torch::kCPU};
};

LoadedPolicy::LoadedPolicy(const std::string& run_dir, const std::string& checkpoint,
                           const std::string& device)
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
  const CheckpointMeta m = read_checkpoint_meta(path);
  if (impl_->cfg.suite.empty()) {
    const auto& spec = tasks::find_task(impl_->cfg.task).spec();
    check_meta(m, path, impl_->cfg.task, spec.obs.dim(), spec.act.dim(), "run " + run_dir);
  } else {  // a suite's widths are checked against its pack in evaluate
    check_meta(m, path, impl_->cfg.suite, 0, 0, "run " + run_dir);
  }
  check_algo(m, path, impl_->cfg.algo, "run " + run_dir);
  impl_->meta = m;
  TrainConfig on = impl_->cfg;
  on.device = device;
  const torch::Device dev = pick_device(on, "--device");
  impl_->algo = make_algorithm(impl_->cfg.algo, impl_->cfg, m.obs_dim, m.act_dim, 0, dev);
  torch::serialize::InputArchive root;
  load_checkpoint(path, root, dev);
  impl_->algo->load_actor(root, path);
  impl_->device = dev;
}

torch::Tensor LoadedPolicy::act(const torch::Tensor& obs, bool sample) {
  auto o = obs.to(impl_->device);
  return sample ? impl_->algo->sample_actor(o) : impl_->algo->actor(o);
}

LoadedPolicy::~LoadedPolicy() = default;
const TrainConfig& LoadedPolicy::config() const { return impl_->cfg; }
const std::string& LoadedPolicy::checkpoint() const { return impl_->checkpoint; }
int64_t LoadedPolicy::obs_dim() const { return impl_->meta.obs_dim; }
int64_t LoadedPolicy::act_dim() const { return impl_->meta.act_dim; }
int64_t LoadedPolicy::update() const { return impl_->meta.update; }

void LoadedPolicy::act(const float* obs, int n, float* actions) {
  auto o = torch::from_blob(const_cast<float*>(obs), {n, impl_->meta.obs_dim}, torch::kFloat32);
  auto a = act(o, false).to(torch::kCPU).contiguous();
  std::memcpy(actions, a.data_ptr<float>(), sizeof(float) * n * impl_->meta.act_dim);
}

Adaptive* LoadedPolicy::adaptive() { return impl_->algo->adaptive(); }

void LoadedPolicy::check_fits(const taskpack::Pack& pack, const std::string& what) const {
  if (pack.obs_dim() != obs_dim() || pack.act_dim() != act_dim())
    throw Error("checkpoint " + checkpoint() + " has observations " + std::to_string(obs_dim()) +
                " and actions " + std::to_string(act_dim()) + "; " + what + " has " +
                std::to_string(pack.obs_dim()) + " and " + std::to_string(pack.act_dim()));
}

void set_policy_threads(int threads) {
  if (threads > 0) torch::set_num_threads(threads);
}

EvalResult evaluate(LoadedPolicy& policy, int episodes, uint64_t seed, int threads,
                    const std::string& task_config, bool progress) {
  TrainConfig c = policy.config();
  if (!task_config.empty()) {
    if (!c.suite.empty())
      throw Error("eval: a task YAML (--task-config " + task_config +
                  ") replaces a task run's own; this run trained on the suite " + c.suite);
    c.task_config = task_config;
  }
  return evaluate_actions(c, episodes, seed, threads, [&](const taskpack::TaskPack& env) {
    policy.check_fits(env, c.target() + " now");
    return [&policy](const float* obs, int n, float* act) { policy.act(obs, n, act); };
  }, "train", progress);
}

EvalResult evaluate_random(const TrainConfig& c, int episodes, uint64_t seed, int threads,
                           const std::string& split, bool progress) {
  std::mt19937_64 rng(seed ^ 0x5DEECE66Dull);
  auto make = [&rng](const taskpack::TaskPack& env) -> Actor {
    const int A = env.act_dim();
    return [&rng, A](const float*, int n, float* act) {
      for (int64_t i = 0; i < int64_t(n) * A; ++i)
        act[i] = static_cast<float>(sim::uniform(rng, -1, 1));
    };
  };
  return evaluate_actions(c, episodes, seed, threads, make, split, progress);
}

EvalResult evaluate_zero(const TrainConfig& c, int episodes, uint64_t seed, int threads,
                         const std::string& split, bool progress) {
  auto make = [](const taskpack::TaskPack& env) -> Actor {
    const int A = env.act_dim();
    return [A](const float*, int n, float* act) { std::fill_n(act, int64_t(n) * A, 0.0f); };
  };
  return evaluate_actions(c, episodes, seed, threads, make, split, progress);
}

EvalResult evaluate_actions(const TrainConfig& c, int episodes, uint64_t seed, int threads,
                            const ActorFactory& make_actor, const std::string& split,
                            bool progress) {
  taskpack::TaskPack env(eval_pack(c, split, episodes, false), run_pack_options(c, seed, threads));
  const Actor actor = make_actor(env);
  env.reset();
  const int n = env.nslot();
  std::vector<float> act(size_t(n) * env.act_dim());
  std::vector<double> ret(n, 0.0), done_ret(n, 0.0);
  std::vector<int> len(n, 0), done_len(n, 0);
  std::vector<uint8_t> finished(n, 0), succ(n, 0);
  int left = n;
  EvalResult r;
  std::optional<Progress> bar;
  if (progress) bar.emplace("eval " + c.target(), n, "episodes");
  while (left > 0) {
    if (bar) bar->update(n - left);
    actor(env.obs.data(), n, act.data());
    env.step(act);
    for (int s = 0; s < n; ++s) {
      if (env.fault[s]) r.faults += 1;
      if (finished[s]) continue;
      // unscaled: the task's own reward (a suite's scale is for learning only)
      const int g = env.group_of(s);
      ret[s] += env.group(g).reward[s - env.group_begin(g)];
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
  if (bar) {
    bar->update(n);
    bar->finish();
  }
  // per entry, then the mean over entries (one entry: over its episodes)
  double mr = 0, ml = 0, ms = 0, sd = 0;
  for (int g = 0; g < env.ngroups(); ++g) {
    EntryScore e;
    e.label = env.label(g);
    e.task = env.entry(g).task;
    double sum = 0, sq = 0, ls = 0, ss = 0;
    const int b = env.group_begin(g), k = env.group(g).nslot();
    for (int s = b; s < b + k; ++s) {
      sum += done_ret[s];
      sq += done_ret[s] * done_ret[s];
      ls += done_len[s];
      ss += succ[s];
    }
    e.episodes = k;
    e.mean_return = sum / k;
    e.success = ss / k;
    mr += e.mean_return;
    ms += e.success;
    ml += ls / k;
    sd += std::sqrt(std::max(0.0, sq / k - e.mean_return * e.mean_return));
    r.per_task.push_back(e);
  }
  const double G = env.ngroups();
  r.episodes = n;
  r.mean_return = mr / G;
  r.std_return = sd / G;
  r.mean_length = ml / G;
  r.success_rate = ms / G;
  return r;
}

MetaEvalResult evaluate_meta(LoadedPolicy& policy, const std::string& split, int episodes,
                             int adapt_episodes, int adapt_steps, uint64_t seed, int threads,
                             bool progress) {
  const TrainConfig& c = policy.config();
  Adaptive* adapt = policy.adaptive();
  if (!adapt)
    throw Error("run of " + c.target() + " trained " + c.algo + ", which does not adapt to a " +
                "task: --split, --adapt-episodes and --adapt-steps evaluate meta-RL runs (" +
                "maml, promp, rl2); evaluate this run without them");
  if (split != "train" && split != "test")
    throw ConfigError("--split", "split", "train or test", "'" + split + "'");
  check_meta_suite(taskpack::load_suite(c.suite), policy.checkpoint());
  if (episodes < 1 || adapt_episodes < 1 || adapt_steps < 0)
    throw Error("meta evaluation: --episodes and --adapt-episodes must be >= 1 and "
                "--adapt-steps >= 0 (got " + std::to_string(episodes) + ", " +
                std::to_string(adapt_episodes) + ", " + std::to_string(adapt_steps) + ")");
  const taskpack::PackSpec ps = eval_pack(c, split, episodes, true);
  taskpack::TaskPack env(ps, run_pack_options(c, seed, threads));
  policy.check_fits(env, "the " + split + " split of " + c.suite);
  torch::manual_seed(seed);
  const torch::Device cpu(torch::kCPU);
  auto collector = make_collector(env, cpu);
  int ntasks = 0;
  const std::vector<int> tasks = env.slot_tasks(&ntasks);
  const int n = env.nslot();
  MetaEvalResult r;
  r.split = split;
  r.adapt_episodes = adapt_episodes;
  r.adapt_steps = adapt->takes_steps() ? adapt_steps : 0;  // RL^2: none, whatever was asked
  // every slot's episodes of the three phases: one before, the adaptation's, one after
  std::optional<Progress> bar;
  int64_t finished = 0;
  if (progress)
    bar.emplace("eval " + c.target() + " (" + split + ")", int64_t(n) * (adapt_episodes + 2),
                "episodes");
  // Runs every slot from a reset until it has finished `count` episodes; returns each slot's
  // first episode's unscaled return and success.
  auto phase = [&](bool explore, int count, std::vector<double>* ret, std::vector<uint8_t>* succ) {
    torch::NoGradGuard ng;
    torch::Tensor obs = collector->reset();
    std::vector<int> left(n, count);
    std::vector<double> acc(n, 0.0);
    ret->assign(n, 0.0);
    succ->assign(n, 0);
    int busy = n;
    auto keep = torch::ones({n});
    while (busy > 0) {
      Transition t = collector->step(explore ? adapt->explore(obs) : adapt->exploit(obs));
      adapt->observe(t, keep);
      auto k = keep.accessor<float, 1>();
      for (int s = 0; s < n; ++s) {
        if (env.fault[s]) r.faults += 1;
        if (!left[s]) continue;
        const int g = env.group_of(s);
        acc[s] += env.group(g).reward[s - env.group_begin(g)];
        if (!(env.terminated[s] || env.truncated[s])) continue;
        if (left[s] == count) {
          (*ret)[s] = acc[s];
          (*succ)[s] = env.success[s];
        }
        acc[s] = 0;
        ++finished;
        if (--left[s] == 0) {
          k[s] = 0;
          --busy;
        }
      }
      obs = t.obs;
      if (bar) bar->update(finished);
    }
  };
  std::vector<double> before, after, unused;
  std::vector<uint8_t> sb, sa, unused_s;
  adapt->begin(tasks, ntasks);
  phase(false, 1, &before, &sb);
  adapt->begin(tasks, ntasks);
  phase(true, adapt_episodes, &unused, &unused_s);
  adapt->adapt(adapt_steps);
  phase(false, 1, &after, &sa);
  if (bar) bar->finish();
  for (int g = 0; g < env.ngroups(); ++g) {
    AdaptScore a;
    a.label = env.label(g);
    a.task = env.entry(g).task;
    const int b = env.group_begin(g), k = env.group(g).nslot();
    for (int s = b; s < b + k; ++s) {
      a.return_before += before[s] / k;
      a.return_after += after[s] / k;
      a.success_before += double(sb[s]) / k;
      a.success_after += double(sa[s]) / k;
    }
    a.episodes = k;
    r.return_before += a.return_before / env.ngroups();
    r.return_after += a.return_after / env.ngroups();
    r.success_before += a.success_before / env.ngroups();
    r.success_after += a.success_after / env.ngroups();
    r.per_task.push_back(a);
  }
  return r;
}

}  // namespace bidex::rl
