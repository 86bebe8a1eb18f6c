// bidex train / eval: PPO on a task or multi-task PPO on a suite, with a run folder (config,
// metrics, learning curve, checkpoints) and a record in the registry; resuming a stopped run;
// evaluating a trained (or a random) policy.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "core/clock.h"
#include "core/error.h"
#include "core/files.h"
#include "core/version.h"
#include "marl/agents.h"
#include "offline/dataset.h"
#include "offline/recorder.h"
#include "registry/registry.h"
#include "rl/algorithms.h"
#include "rl/config.h"
#include "rl/metrics.h"
#include "rl/trainer.h"
#include "sim/hand_spec.h"
#include "taskpack/suite.h"
#include "tasks/registry.h"

namespace bidex::apps {

namespace {
std::string num(double v, const char* f = "%.4g") {
  if (!std::isfinite(v)) return "n/a";
  char buf[48];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// The learning curve as text: about ten rows of slot-steps, mean return and success rate (the
// updates in which episodes ended), with a bar for the return.
void print_curve(const std::string& dir) {
  std::vector<std::string> cols;
  std::vector<std::vector<double>> rows;
  rl::parse_metrics_csv(read_file(dir + "/metrics.csv"), dir + "/metrics.csv", cols, rows);
  size_t is = 0, ir = 0, ic = 0;
  for (size_t i = 0; i < cols.size(); ++i) {
    if (cols[i] == "steps") is = i;
    if (cols[i] == "return") ir = i;
    if (cols[i] == "success") ic = i;
  }
  std::vector<const std::vector<double>*> ended;
  for (auto& r : rows)
    if (std::isfinite(r[ir])) ended.push_back(&r);
  if (ended.empty()) return;
  double lo = INFINITY, hi = -INFINITY;
  for (auto* r : ended) {
    lo = std::min(lo, (*r)[ir]);
    hi = std::max(hi, (*r)[ir]);
  }
  std::printf("%12s %10s %8s\n", "slot-steps", "return", "success");
  const size_t n = ended.size(), shown = std::min<size_t>(n, 10);
  for (size_t k = 0; k < shown; ++k) {
    const auto& r = *ended[shown == 1 ? n - 1 : k * (n - 1) / (shown - 1)];
    const int bar = hi > lo ? static_cast<int>(30 * (r[ir] - lo) / (hi - lo) + 0.5) : 0;
    std::printf("%12.0f %10.4g %8.3f  %s\n", r[is], r[ir], r[ic], std::string(bar, '#').c_str());
  }
}
}  // namespace

std::string absolute(const std::string& path) {
  char* r = ::realpath(path.c_str(), nullptr);
  if (!r) return path;
  std::string out = r;
  std::free(r);
  return out;
}

std::string record_dataset(registry::Registry& reg, const std::string& path) {
  const offline::DatasetInfo d = offline::read_info(path);
  registry::DatasetRecord r;
  r.checksum = d.checksum;
  r.dataset_id = d.dataset_id;
  r.task = d.task;
  r.quality = d.quality;
  r.path = absolute(offline::dataset_dir(path));
  r.total_steps = d.total_steps;
  r.total_episodes = d.total_episodes;
  if (std::isfinite(d.ref_min_score)) r.ref_min = d.ref_min_score;
  if (std::isfinite(d.ref_max_score)) r.ref_max = d.ref_max_score;
  r.policy = d.policy;
  r.code_version = d.code_version;
  reg.put_dataset(r);
  return r.checksum;
}

// The YAML a task's run plays when it is not the task's own (a training aid, such as
// re_orientation's reward for progress in its section of configs/train/ppo.yaml), or "" when it
// is the task's own or the run is a suite's. Scores under such a YAML are on its reward, not on
// the scale of the registry's references, so the registry does not store them.
std::string foreign_task_yaml(const std::string& task, const std::string& yaml) {
  if (task.empty() || yaml.empty()) return "";
  std::error_code ec;
  if (std::filesystem::equivalent(sim::resolve_data_path(yaml), tasks::default_task_config(task), ec))
    return "";
  return yaml;
}

// One run's row in the registry: created when the run folder is ready (its id kept in
// <run>/registry.json, so that --resume updates the same row), completed when training ends.
class RunRecorder {
 public:
  explicit RunRecorder(std::string path) : path_(std::move(path)) {}
  bool enabled() const { return !path_.empty(); }

  void start(const rl::TrainConfig& c, const std::string& run_dir) {
    if (!enabled()) return;
    reg_ = std::make_unique<registry::Registry>(path_);
    foreign_ = foreign_task_yaml(c.task, c.task_config);
    const std::string link = run_dir + "/registry.json";
    const std::string abs_reg = absolute(path_);
    if (::access(link.c_str(), F_OK) == 0) {  // a resumed run: the same row, if it is in this registry
      try {
        auto j = nlohmann::json::parse(read_file(link));
        if (j.value("registry", "") == abs_reg) id_ = j.at("run_id").get<int64_t>();
      } catch (const std::exception&) {
        id_ = 0;
      }
      if (auto r = reg_->run(id_)) rec_ = *r;
      else id_ = 0;
    }
    if (id_ == 0) {
      rec_ = registry::RunRecord{};
      rec_.algo = c.algo;
      rec_.task = c.task;
      rec_.suite = c.suite;
      rec_.seed = c.seed;
      rec_.config_hash = rl::config_hash(read_file(run_dir + "/config.yaml"));
      rec_.code_version = code_version();
      rec_.run_dir = absolute(run_dir);
      rec_.status = "running";
      if (!c.dataset.empty()) rec_.dataset = record_dataset(*reg_, c.dataset);
      id_ = reg_->begin_run(rec_);  // the registry fills in the host and the start time
      rec_ = *reg_->run(id_);
      nlohmann::json j = {{"registry", abs_reg}, {"run_id", id_}};
      write_file_atomic(link, j.dump(2) + "\n");
    }
  }

  void finish(const rl::TrainResult* r, const std::string& status) {
    if (!reg_ || id_ == 0) return;
    rec_.status = status;
    rec_.finished.clear();  // the registry writes the end time
    std::vector<registry::TaskScore> scores;
    if (r) rec_.steps = r->steps;
    if (r && foreign_.empty()) {  // a run under a foreign YAML: returns on another reward
      if (std::isfinite(r->last_return)) rec_.final_return = r->last_return;
      if (std::isfinite(r->last_success)) rec_.final_success = r->last_success;
      for (auto& e : r->scores) {
        if (e.episodes == 0) continue;
        registry::TaskScore t;
        t.task = e.task;
        t.label = e.label;
        t.mean_return = e.mean_return;
        if (std::isfinite(e.success)) t.success = e.success;
        t.episodes = e.episodes;
        scores.push_back(t);
      }
    }
    reg_->finish_run(id_, rec_, scores);
  }

  // "normalised 0.42" (or why not) for a task's mean return; an offline run's against its
  // dataset's references, on the paper's scale (random 0, online PPO 100).
  std::string normalised(const std::string& task, double mean_return) const {
    if (!reg_ || !std::isfinite(mean_return)) return "";
    if (!foreign_.empty())
      return "normalised n/a: trained under " + foreign_ + ", whose reward is not the registry's "
             "scale; the registry stores no score of it (bidex eval --run DIR --task-config " +
             tasks::default_task_config(task) + " stores its mean action's)";
    if (!rec_.dataset.empty()) {
      auto n = reg_->offline_normalised(rec_.dataset, mean_return);
      return n ? "normalised score " + num(*n, "%.1f") + " (random 0, online PPO 100)"
               : "normalised score n/a (the dataset's task has no reference scores)";
    }
    auto n = reg_->normalised(task, mean_return);
    return n ? "normalised " + num(*n, "%.3f") : "normalised n/a (no reference scores)";
  }
  int64_t id() const { return id_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::unique_ptr<registry::Registry> reg_;
  registry::RunRecord rec_;
  int64_t id_ = 0;
  std::string foreign_;  // foreign_task_yaml of the run
};

// The final scores of a run, one line per task of a suite.
void print_scores(const rl::TrainResult& r, const RunRecorder& rec) {
  if (r.scores.size() < 2) {
    if (r.scores.size() == 1 && rec.enabled())
      std::printf("%s\n", rec.normalised(r.scores[0].task, r.scores[0].mean_return).c_str());
    return;
  }
  std::printf("%-24s %10s %8s %9s  (episodes of the last 10 updates)\n", "task", "return",
              "success", "episodes");
  for (auto& e : r.scores)
    std::printf("%-24s %10s %8s %9lld  %s\n", e.label.c_str(), num(e.mean_return).c_str(),
                num(e.success, "%.3f").c_str(), static_cast<long long>(e.episodes),
                rec.normalised(e.task, e.mean_return).c_str());
}

// "ippo, mappo, happo, hatrpo, maddpg": the multi-agent algorithms.
std::string marl_names() {
  std::string s;
  for (auto& a : rl::algorithm_registry())
    if (a.multi_agent) s += (s.empty() ? "" : ", ") + a.name;
  return s;
}

// "bc, bcq, td3bc, iql": the offline algorithms.
std::string offline_names() {
  std::string s;
  for (auto& a : rl::algorithm_registry())
    if (a.trains_on == rl::TrainsOn::kDataset) s += (s.empty() ? "" : ", ") + a.name;
  return s;
}

void add_train_command(CLI::App& app) {
  struct Opts {
    std::string task, suite, algo, config, run, resume, registry, dataset, replay, agents;
    std::vector<std::string> overrides;
    int64_t stop_after = 0, replay_steps = 1000000;
    double time_limit = 0, wall_limit = 0;
    bool no_registry = false, profile = false;
    std::string device = "auto";
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "train", "Train a policy on a task (PPO) or a suite (multi-task PPO); writes a run folder "
               "with config.yaml, metrics.csv/.jsonl, learning_curve.svg and checkpoints/, "
               "records the run in the registry, and resumes a run");
  cmd->add_option("--task", o->task, "Task id (see bidex info --task ID)");
  cmd->add_option("--suite", o->suite,
                  "Suite id (MT1, MT4, MT20; see configs/suites) or a suite YAML file");
  cmd->add_option("--algo", o->algo,
                  "Algorithm (" + rl::algorithm_names() + "): ppo is the default with --task, "
                  "mtppo with --suite");
  cmd->add_option("--config", o->config,
                  "Training defaults YAML (default: configs/train/<algo>.yaml)");
  cmd->add_option("--dataset", o->dataset,
                  "Offline algorithms (bc, bcq, td3bc, iql): the dataset to learn from (a folder "
                  "of bidex collect, or its main_data.hdf5); its task is the run's");
  cmd->add_option("--agents", o->agents,
                  "Multi-agent algorithms (" + marl_names() + "): hand (one agent per hand, the "
                  "default), finger (palm and each finger of each hand), or a YAML file of "
                  "agents (marl/README.md)");
  cmd->add_option("--record-replay", o->replay,
                  "Also write the run's first --replay-steps transitions as a replay dataset in "
                  "this folder (a share of the slots, reaching the count about halfway through)");
  cmd->add_option("--replay-steps", o->replay_steps, "Transitions of --record-replay")
      ->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_option("--registry", o->registry,
                  "Registry file the run is recorded in (default: $BIDEX_REGISTRY, else "
                  "runs/registry.sqlite)");
  cmd->add_flag("--no-registry", o->no_registry, "Do not record the run in a registry");
  cmd->add_option("-o,--override", o->overrides,
                  "Change one setting, key.path=value (repeatable), e.g. -o ppo.lr=1e-3 "
                  "-o env.slots=256 -o train.steps=2e6");
  cmd->add_option("--run", o->run, "Run folder to create (default: runs/<task>-<algo>-<time>-s<seed>)");
  cmd->add_option("--resume", o->resume, "Continue the run in this folder from its newest checkpoint");
  cmd->add_option("--stop-after", o->stop_after,
                  "Stop as Ctrl-C would after this many updates in total (for tests and "
                  "staged runs)");
  cmd->add_option("--time-limit", o->time_limit,
                  "Stop as Ctrl-C would once this session has trained this many seconds "
                  "(a checkpoint is written; --resume continues)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--wall-limit", o->wall_limit,
                  "Stop as Ctrl-C would once this many seconds have passed since the command "
                  "started, its setup (building the scenes, compiling GPU kernels) included, "
                  "after at least one update (a checkpoint is written; --resume continues): for "
                  "a run that must end by a deadline")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--device", o->device,
                  "Where the simulation steps: cpu (MuJoCo on all cores), cuda (MuJoCo Warp on "
                  "the GPU; the learner reads its rows in place), or auto: cuda when there is a "
                  "GPU, the GPU backend and a CUDA LibTorch; warp-cpu runs the GPU path's code on "
                  "Warp's CPU device (tests). Recorded in run.json; a resumed run may change it")
      ->check(CLI::IsMember({"auto", "cpu", "cuda", "warp-cpu"}))->capture_default_str();
  cmd->add_flag("--profile", o->profile,
                "Also time physics, task kernels, policy and update, into <run>/profile.json "
                "(the simulation waits after each stage)");
  cmd->footer(
      "Examples:\n"
      "  bidex train --task catch_underarm_raise          # a small run, about 10 s on 2 cores\n"
      "  bidex train --task hand_over --algo ppo -o env.slots=64 -o train.steps=200000\n"
      "  bidex train --task hand_over --algo trpo -o trpo.max_kl=0.05\n"
      "  bidex train --task hand_over --algo sac -o env.slots=64 -o sac.batch_size=256\n"
      "  bidex train --suite MT4 --algo mtppo -o env.slots=256\n"
      "  bidex train --suite MT4 --algo mttrpo -o env.slots=256\n"
      "  bidex train --task hand_over --device cuda -o env.slots=16384   # on the GPU\n"
      "  bidex train --resume runs/hand_over-ppo-20261122-120000-s0\n"
      "  bidex train --algo td3bc --dataset datasets/hand_over/expert-v0\n"
      "  bidex train --task hand_over --record-replay datasets/hand_over/replay-v0\n"
      "  bidex train --task hand_over --algo happo --agents finger\n"
      "Ctrl-C writes a checkpoint and stops; --resume continues from it.");
  cmd->callback([o] {
    const double started = monotonic_seconds();
    request_gpu_queues(o->device);
    rl::TrainOptions to;
    to.command = command_line();
    to.stop_after_updates = o->stop_after;
    to.time_limit_s = o->time_limit;
    if (o->wall_limit > 0) to.stop_at_monotonic_s = started + o->wall_limit;
    to.device = o->device;
    to.profile = o->profile;
    if (o->no_registry && !o->registry.empty())
      throw Error("train: --registry and --no-registry contradict each other");
    auto rec = std::make_shared<RunRecorder>(
        o->no_registry ? "" : (o->registry.empty() ? registry::default_path() : o->registry));
    to.on_start = [rec](const rl::TrainConfig& c, const std::string& dir) { rec->start(c, dir); };
    rl::TrainResult r;
    try {
      if (!o->resume.empty()) {
        if (!o->task.empty() || !o->suite.empty() || !o->overrides.empty() ||
            !o->config.empty() || !o->run.empty() || !o->algo.empty() || !o->dataset.empty() ||
            !o->agents.empty())
          throw Error("--resume continues a run with its own config.yaml: drop --task, --suite, "
                      "--algo, --dataset, --agents, --config, --run and -o");
        if (!o->replay.empty())
          throw Error("--record-replay records a run's stream from its first step: it goes "
                      "with a new run, not --resume");
        r = rl::train_resume(o->resume, to);
      } else {
        std::string dataset;
        if (!o->dataset.empty()) {
          // the task comes from the dataset (checked against --task), before anything else
          const offline::DatasetInfo d = offline::read_info(o->dataset);
          if (!o->task.empty() && o->task != d.task)
            throw ConfigError("--task", "task", "the dataset's task (" + d.task + ", " +
                              o->dataset + ")", o->task);
          if (!o->suite.empty())
            throw Error("train: --dataset is of one task; drop --suite");
          o->task = d.task;
          dataset = absolute(offline::dataset_dir(o->dataset));
        }
        if (o->task.empty() == o->suite.empty())
          throw Error("train: give one of --task ID and --suite ID (or --resume DIR)");
        const std::string algo = !o->algo.empty() ? o->algo : (o->suite.empty() ? "ppo" : "mtppo");
        const bool offline_algo = rl::find_algorithm(algo).trains_on == rl::TrainsOn::kDataset;
        if (offline_algo != !dataset.empty())
          throw Error(offline_algo ? "train: --algo " + algo + " learns from a dataset: give "
                                     "--dataset (bidex collect writes one)"
                                   : "train: --dataset goes with an offline algorithm (" +
                                         offline_names() + "); --algo " + algo +
                                         " learns from what it collects");
        if (!o->replay.empty()) to.recorder = offline::replay_recorder(o->replay, o->replay_steps,
                                                                       command_line());
        // unknown algorithm: the error lists the known ones
        const bool on_suite = rl::find_algorithm(algo).trains_on == rl::TrainsOn::kSuite;
        if (on_suite && o->suite.empty())
          throw Error("train: --algo " + algo + " trains on a suite: give --suite (" +
                      taskpack::known_suites_text(rl::find_algorithm(algo).meta) + ")");
        // "--algo mtppo or --algo mttrpo": the multi-task ones, or the meta-RL ones
        auto suite_algos = [](bool meta) {
          std::string s;
          for (auto& a : rl::algorithm_registry())
            if (a.trains_on == rl::TrainsOn::kSuite && a.meta == meta)
              s += (s.empty() ? "--algo " : " or --algo ") + a.name;
          return s;
        };
        if (!on_suite && o->task.empty())
          throw Error("train: --algo " + algo + " trains on one task: give --task, or use " +
                      suite_algos(false) + " for a multi-task suite, " + suite_algos(true) +
                      " for a meta-learning suite");
        if (!o->task.empty()) tasks::find_task(o->task);  // unknown id: lists the known ones
        if (!o->suite.empty()) {
          const taskpack::Suite su = taskpack::load_suite(o->suite);  // unknown: lists them
          const bool meta = rl::find_algorithm(algo).meta;
          if (!meta && su.mode != taskpack::PackMode::kMultiTask)
            throw Error("train: suite " + o->suite + " is a meta-learning suite (goal slices "
                        "masked, no task id): " + suite_algos(true) + " meta-train on its train "
                        "split; " + suite_algos(false) + " train the multi-task suites (" +
                        taskpack::known_suites_text(false) + ")");
        }
        const std::string file = o->config.empty() ? rl::default_train_config(algo) : o->config;
        const std::string target = o->suite.empty() ? o->task : o->suite;
        std::vector<std::string> overrides = o->overrides;
        if (!o->agents.empty()) {
          const rl::AlgorithmInfo info = rl::find_algorithm(algo);
          if (!info.multi_agent)
            throw Error("train: --agents goes with a multi-agent algorithm (" + marl_names() +
                        "); --algo " + algo + " acts as one agent");
          // checked against the task's layout now; a file's errors name it
          std::string value;
          marl::agents_from_arg(tasks::find_task(o->task).spec(), o->agents, &value);
          overrides.insert(overrides.begin(), info.section + ".agents=" + value);
        }
        const std::string yaml =
            rl::resolve_train_yaml(file, algo, target, overrides, dataset);
        const rl::TrainConfig c = rl::parse_train_config(yaml, file);
        const std::string dir = o->run.empty() ? rl::default_run_dir(c) : o->run;
        r = rl::train_new(yaml, dir, to);
      }
    } catch (...) {
      rec->finish(nullptr, "failed");  // a run that started and then failed is kept as failed
      throw;
    }
    rec->finish(&r, r.interrupted ? "stopped" : "finished");
    const std::string cfg_file = r.run_dir + "/config.yaml";
    const bool offline_run =
        !rl::parse_train_config(read_file(cfg_file), cfg_file).dataset.empty();
    std::printf("run %s: %lld updates, %lld %s; last mean return %s, success rate %s\n",
                r.run_dir.c_str(), static_cast<long long>(r.updates),
                static_cast<long long>(r.steps),
                offline_run ? "gradient steps" : "slot-steps", num(r.last_return).c_str(),
                num(r.last_success, "%.3f").c_str());
    print_scores(r, *rec);
    std::printf("simulation on %s\n", r.sim_device.c_str());
    if (!r.room_advice.empty()) std::printf("%s\n", r.room_advice.c_str());
    if (rec->id() > 0)
      std::printf("registry %s: run %lld\n", rec->path().c_str(), static_cast<long long>(rec->id()));
    print_curve(r.run_dir);
    std::printf("checkpoint %s\nlearning curve %s/learning_curve.svg\n", r.checkpoint.c_str(),
                r.run_dir.c_str());
    if (r.interrupted) {
      std::printf("stopped early: continue with  bidex train --resume %s\n", r.run_dir.c_str());
      std::fflush(stdout);
      std::exit(130);
    }
  });
}

// Stores an evaluation of the run in `run_dir` (its fields but run_id) as one of that run's in
// `reg` and says so; a run the registry did not record is said, not stored. Returns its id or 0.
int64_t store_evaluation(registry::Registry& reg, const std::string& run_dir,
                         registry::Evaluation ev) {
  const auto run = reg.run_by_dir(absolute(run_dir));
  if (!run) {
    std::printf("registry %s: run %s is not recorded there (trained with --no-registry or "
                "another --registry); the evaluation is not stored\n",
                reg.path().c_str(), run_dir.c_str());
    return 0;
  }
  ev.run_id = run->id;
  const int64_t id = reg.add_evaluation(ev);
  std::printf("registry %s: evaluation %lld of run %lld (bidex registry evals --run %lld; "
              "bidex registry report age --eval %lld)\n",
              reg.path().c_str(), static_cast<long long>(id), static_cast<long long>(run->id),
              static_cast<long long>(run->id), static_cast<long long>(id));
  return id;
}

// bidex eval --run DIR --split train|test: meta-RL's protocol (rl::evaluate_meta), printed per
// task, stored in the registry that recorded the run, and written to --json.
template <class Opts>
void eval_meta(const Opts& o, rl::LoadedPolicy& policy) {
  if (!o.task.empty() || !o.suite.empty() || o.set_reference || !o.task_config.empty())
    throw Error("eval: --task, --suite, --task-config and --set-reference go with --random");
  const std::string split = o.split.empty() ? "test" : o.split;
  const rl::MetaEvalResult r = rl::evaluate_meta(policy, split, o.episodes, o.adapt_episodes,
                                                 o.adapt_steps, o.seed, o.threads, true);
  const auto& c = policy.config();
  std::printf("%s, %s split, checkpoint %s (update %lld): %d episode(s) per task; adaptation "
              "from %d episode(s) per slot, %d step(s)\n",
              c.suite.c_str(), split.c_str(), policy.checkpoint().c_str(),
              static_cast<long long>(policy.update()), o.episodes, r.adapt_episodes,
              r.adapt_steps);
  std::optional<registry::Registry> reg;
  if (!o.no_registry) reg.emplace(o.registry.empty() ? registry::default_path() : o.registry);
  // the scores as the registry stores them, normalised with its references
  std::vector<registry::AdaptScore> scores;
  for (auto& e : r.per_task) {
    registry::AdaptScore a;
    a.task = e.task;
    a.label = e.label;
    a.return_before = e.return_before;
    a.return_after = e.return_after;
    a.success_before = e.success_before;
    a.success_after = e.success_after;
    a.episodes = e.episodes;
    scores.push_back(a);
  }
  registry::AdaptNormalised norm;
  if (reg) {
    norm = reg->normalised_scores(scores);
  } else {
    norm.before.assign(scores.size(), std::nullopt);
    norm.after.assign(scores.size(), std::nullopt);
  }
  auto opt_json = [](const std::optional<double>& v) {
    return v ? nlohmann::json(*v) : nlohmann::json();
  };
  std::printf("%-20s %-22s %16s %16s %11s %10s\n", "task", "id", "return before",
              "return after", "norm before", "norm after");
  nlohmann::json per = nlohmann::json::array();
  for (size_t i = 0; i < scores.size(); ++i) {
    const auto& e = scores[i];
    std::printf("%-20s %-22s %16s %16s %11s %10s\n", e.label.c_str(), e.task.c_str(),
                num(e.return_before).c_str(), num(e.return_after).c_str(),
                norm.before[i] ? num(*norm.before[i], "%.3f").c_str() : "-",
                norm.after[i] ? num(*norm.after[i], "%.3f").c_str() : "-");
    per.push_back({{"label", e.label}, {"task", e.task}, {"episodes", e.episodes},
                   {"return_before", e.return_before}, {"return_after", e.return_after},
                   {"success_before", opt_json(e.success_before)},
                   {"success_after", opt_json(e.success_after)},
                   {"normalised_before", opt_json(norm.before[i])},
                   {"normalised_after", opt_json(norm.after[i])}});
  }
  std::printf("mean: return %s -> %s, success %.3f -> %.3f, faults %lld\n",
              num(r.return_before).c_str(), num(r.return_after).c_str(), r.success_before,
              r.success_after, static_cast<long long>(r.faults));
  if (norm.count > 0) {
    std::printf("normalised (random 0, ground truth 1): %s -> %s, the mean of %d of %zu "
                "entries%s\n",
                num(*norm.mean_before, "%.3f").c_str(), num(*norm.mean_after, "%.3f").c_str(),
                norm.count, scores.size(),
                norm.count < static_cast<int>(scores.size())
                    ? " (the others' tasks lack a reference: bidex registry reference)"
                    : "");
  } else {
    std::printf("normalised: none (%s)\n",
                reg ? "no task here has both references in the registry: bidex registry "
                      "reference"
                    : "--no-registry");
  }
  int64_t eval_id = 0;
  if (reg) {
    registry::Evaluation ev;
    ev.split = split;
    ev.adapt_episodes = r.adapt_episodes;
    ev.adapt_steps = r.adapt_steps;
    ev.seed = o.seed;
    ev.checkpoint = policy.checkpoint();
    ev.scores = scores;
    eval_id = store_evaluation(*reg, o.run, ev);
  }
  if (!o.json.empty()) {
    nlohmann::json j = {{"run", o.run},
                        {"suite", c.suite},
                        {"algo", c.algo},
                        {"split", split},
                        {"checkpoint", policy.checkpoint()},
                        {"update", policy.update()},
                        {"episodes_per_task", o.episodes},
                        {"adapt_episodes", r.adapt_episodes},
                        {"adapt_steps", r.adapt_steps},
                        {"return_before", r.return_before},
                        {"return_after", r.return_after},
                        {"success_before", r.success_before},
                        {"success_after", r.success_after},
                        {"normalised_before", opt_json(norm.mean_before)},
                        {"normalised_after", opt_json(norm.mean_after)},
                        {"normalised_entries", norm.count},
                        {"faults", r.faults},
                        {"per_task", per},
                        {"registry_evaluation", eval_id},
                        {"seed", o.seed},
                        {"code_version", code_version()},
                        {"command", command_line()}};
    write_file_atomic(o.json, j.dump(2) + "\n");
  }
}

void add_eval_command(CLI::App& app) {
  struct Opts {
    std::string run, checkpoint, json, task, suite, task_config, registry, split;
    int episodes = 100, threads = 0, adapt_episodes = 1, adapt_steps = 1;
    uint64_t seed = 12345;
    bool random = false, zero = false, set_reference = false, no_registry = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "eval", "Evaluate a trained policy (its mean action), a random policy or the zero action: "
              "mean return and success rate over episodes (per task for a suite)");
  cmd->add_option("--run", o->run, "Run folder of bidex train");
  cmd->add_option("--checkpoint", o->checkpoint, "Checkpoint file (default: the run's newest)");
  cmd->add_flag("--random", o->random,
                "Evaluate a random policy (actions uniform in [-1, 1]) on --task or --suite");
  cmd->add_flag("--zero", o->zero,
                "Evaluate the zero action (every action component 0: no base force, each joint "
                "at its task's action-0 target) on --task or --suite, a baseline beside --random")
      ->excludes("--random");
  cmd->add_option("--task", o->task, "Task id (with --random or --zero)");
  cmd->add_option("--suite", o->suite,
                  "Suite id or file (with --random or --zero): each task of its train split (or "
                  "--split)");
  cmd->add_option("--task-config", o->task_config,
                  "Task YAML (with --random or --zero and --task; default: the task's own), or with "
                  "--run of a task run another YAML of its task to play (default: the run's own), "
                  "e.g. the task's own after training under a curriculum");
  cmd->add_flag("--set-reference", o->set_reference,
                "With --random: store each task's mean return as its 'random' reference score in "
                "the registry");
  cmd->add_option("--registry", o->registry,
                  "Registry file for --set-reference and a run's evaluation (default: "
                  "$BIDEX_REGISTRY, else runs/registry.sqlite)");
  cmd->add_option("--episodes", o->episodes, "Episodes (one per parallel slot; per task for a suite)")
      ->check(CLI::Range(1, 100000))->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the evaluation episodes")->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads of the simulation and of the policy (0: all cores)");
  cmd->add_option("--json", o->json, "Also write the result as JSON to this file");
  auto* split = cmd->add_option(
      "--split", o->split,
      "Meta-RL runs (maml, promp, rl2): the suite's split to adapt to, train or test (default "
      "test); each task is scored before and after adaptation, --episodes slots per task (per "
      "goal of a goal distribution), and normalised with the registry's references (random 0, "
      "ground truth 1). With --random or --zero and --suite: the split to play (default "
      "train)");
  cmd->add_option("--adapt-episodes", o->adapt_episodes,
                  "Meta-RL: episodes per slot that adaptation learns from")
      ->check(CLI::Range(1, 1000))->capture_default_str()->needs(split);
  cmd->add_option("--adapt-steps", o->adapt_steps,
                  "Meta-RL: gradient steps of adaptation (MAML, ProMP; RL^2 adapts in memory)")
      ->check(CLI::Range(0, 1000))->capture_default_str()->needs(split);
  cmd->add_flag("--no-registry", o->no_registry,
                "Do not store a run's evaluation in the registry (by default it goes to the run's "
                "record there, for bidex registry evals and report age --eval)");
  cmd->footer("Examples:\n"
              "  bidex eval --run runs/hand_over-ppo-20261122-120000-s0 --episodes 200\n"
              "  bidex eval --run runs/re_orientation-ppo-20261127-120000-s0 "
              "--task-config tasks/re_orientation/re_orientation.yaml\n"
              "  bidex eval --random --task hand_over --episodes 1000 --set-reference\n"
              "  bidex eval --zero --suite ML20 --split test --episodes 8\n"
              "  bidex eval --run runs/ML1-promp-20261124-070000-s0 --split test "
              "--adapt-episodes 2");
  cmd->callback([o] {
    rl::EvalResult r;
    std::string what, checkpoint, target;
    std::string target_task, policy_config;  // a run's task ("" for a suite's) and its task YAML
    int64_t update = 0;
    rl::set_policy_threads(o->threads);  // --threads: the policy's as the simulation's
    // what is evaluated: a baseline policy (--random, --zero) on a task or suite, or a run's
    const std::string policy = o->random ? "random" : o->zero ? "zero" : "checkpoint";
    if (policy != "checkpoint") {
      const std::string flag = "--" + policy;
      const std::string label = o->random ? "random policy" : "zero action";
      if (!o->run.empty() || !o->checkpoint.empty())
        throw Error("eval: " + flag + " evaluates the " + label +
                    " on --task or --suite, not a run");
      if (o->task.empty() == o->suite.empty())
        throw Error("eval: " + flag + " needs one of --task ID and --suite ID");
      if (o->zero && o->set_reference)
        throw Error("eval: --set-reference stores a random policy's score as the 'random' "
                    "reference; the zero action is not one (use --random)");
      rl::TrainConfig c;
      c.task = o->task;
      c.suite = o->suite;
      c.task_config = o->task_config;
      if (!c.task.empty()) tasks::find_task(c.task);
      if (!o->split.empty() && c.suite.empty())
        throw Error("eval: --split picks a suite's split: give --suite (or --run of a meta-RL "
                    "run)");
      const std::string split = o->split.empty() ? "train" : o->split;
      r = o->random ? rl::evaluate_random(c, o->episodes, o->seed, o->threads, split, true)
                    : rl::evaluate_zero(c, o->episodes, o->seed, o->threads, split, true);
      target = c.target();
      what = target + ", " + label;
    } else {
      if (o->run.empty())
        throw Error("eval: give --run DIR (or --random or --zero with --task or --suite)");
      if (!o->task.empty() || !o->suite.empty() || o->set_reference)
        throw Error("eval: --task, --suite and --set-reference go with --random (--task and "
                    "--suite also with --zero)");
      rl::LoadedPolicy policy(o->run, o->checkpoint);
      if (!o->split.empty() || policy.adaptive()) {  // meta-RL's protocol
        if (!o->task_config.empty())
          throw Error("eval: --task-config goes with a task run, not a meta-RL run's adaptation");
        eval_meta(*o, policy);
        return;
      }
      r = rl::evaluate(policy, o->episodes, o->seed, o->threads, o->task_config, true);
      target = policy.config().target();
      target_task = policy.config().task;
      policy_config = policy.config().task_config;
      what = target;
      if (!o->task_config.empty()) what += " under " + o->task_config;
      checkpoint = policy.checkpoint();
      update = policy.update();
      what += ", checkpoint " + checkpoint + " (update " + std::to_string(update) + ")";
    }
    std::printf("%s: %d episodes, mean return %s (std %s), success rate %.3f, mean length %.1f, "
                "faults %lld\n",
                what.c_str(), r.episodes, num(r.mean_return).c_str(), num(r.std_return).c_str(),
                r.success_rate, r.mean_length, static_cast<long long>(r.faults));
    if (r.per_task.size() > 1) {
      std::printf("%-24s %10s %8s %9s\n", "task", "return", "success", "episodes");
      for (auto& e : r.per_task)
        std::printf("%-24s %10s %8.3f %9lld\n", e.label.c_str(), num(e.mean_return).c_str(),
                    e.success, static_cast<long long>(e.episodes));
    }
    if (o->set_reference) {
      if (!o->random) throw Error("eval: --set-reference stores a random policy's score: add --random");
      if (!o->task_config.empty())
        throw Error("eval: --set-reference records the task's default configuration: drop "
                    "--task-config");
      registry::Registry reg(o->registry.empty() ? registry::default_path() : o->registry);
      for (auto& e : r.per_task) {
        registry::Reference ref;
        ref.task = e.task;
        ref.kind = "random";
        ref.value = e.mean_return;
        ref.source = "bidex eval --random: " + std::to_string(e.episodes) + " episodes, seed " +
                     std::to_string(o->seed) + ", code " + code_version() + ", " + utc_now();
        reg.set_reference(ref);
        std::printf("registry %s: random reference of %s = %s\n", reg.path().c_str(),
                    e.task.c_str(), num(e.mean_return).c_str());
      }
    }
    // a run's mean action, recorded as an evaluation without adaptation (before = after), so
    // that `bidex registry evals` lists it and `bidex registry report age --eval ID` draws it
    int64_t eval_id = 0;
    if (policy == "checkpoint" && !o->no_registry) {
      registry::Registry reg(o->registry.empty() ? registry::default_path() : o->registry);
      const std::string played = o->task_config.empty() ? policy_config : o->task_config;
      const std::string foreign = foreign_task_yaml(target_task, played);
      if (!foreign.empty()) {
        std::printf("registry %s: not stored (played under %s, not the task's own YAML: its "
                    "reward is not the scale of the registry's references; --task-config %s "
                    "plays and stores it)\n",
                    reg.path().c_str(), foreign.c_str(),
                    tasks::default_task_config(target_task).c_str());
      } else {
        registry::Evaluation ev;
        ev.split = "train";
        ev.seed = o->seed;
        ev.checkpoint = checkpoint;
        for (auto& e : r.per_task) {
          registry::AdaptScore a;
          a.task = e.task;
          a.label = e.label;
          a.return_before = a.return_after = e.mean_return;
          a.success_before = a.success_after = e.success;
          a.episodes = e.episodes;
          ev.scores.push_back(a);
        }
        eval_id = store_evaluation(reg, o->run, ev);
      }
    }
    if (!o->json.empty()) {
      nlohmann::json per = nlohmann::json::array();
      for (auto& e : r.per_task)
        per.push_back({{"label", e.label}, {"task", e.task}, {"episodes", e.episodes},
                       {"mean_return", e.mean_return}, {"success_rate", e.success}});
      nlohmann::json j = {{"run", o->run},
                          {"task", target},
                          {"task_config", o->task_config},
                          {"policy", policy},
                          {"checkpoint", checkpoint},
                          {"update", update},
                          {"episodes", r.episodes},
                          {"mean_return", r.mean_return},
                          {"std_return", r.std_return},
                          {"success_rate", r.success_rate},
                          {"mean_length", r.mean_length},
                          {"faults", r.faults},
                          {"per_task", per},
                          {"seed", o->seed},
                          {"code_version", code_version()},
                          {"command", command_line()}};
      if (eval_id > 0) j["registry_evaluation"] = eval_id;
      write_file_atomic(o->json, j.dump(2) + "\n");
    }
  });
}

}  // namespace bidex::apps
