// bidex train / eval: PPO on a task with a run folder (config, metrics, learning curve,
// checkpoints), resuming a stopped run, and evaluating a trained policy.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "core/error.h"
#include "core/files.h"
#include "rl/config.h"
#include "rl/metrics.h"
#include "rl/trainer.h"
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

void add_train_command(CLI::App& app) {
  struct Opts {
    std::string task, algo = "ppo", config, run, resume;
    std::vector<std::string> overrides;
    int64_t stop_after = 0;
    double time_limit = 0;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "train", "Train a policy on a task (PPO); writes a run folder with config.yaml, "
               "metrics.csv/.jsonl, learning_curve.svg and checkpoints/, and resumes one");
  cmd->add_option("--task", o->task, "Task id (see bidex info --task ID)");
  cmd->add_option("--algo", o->algo, "Algorithm (ppo)")->capture_default_str();
  cmd->add_option("--config", o->config,
                  "Training defaults YAML (default: configs/train/<algo>.yaml)");
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
  cmd->footer(
      "Examples:\n"
      "  bidex train --task catch_underarm_raise          # a small run, a few minutes on 2 cores\n"
      "  bidex train --task hand_over --algo ppo -o env.slots=64 -o train.steps=200000\n"
      "  bidex train --resume runs/hand_over-ppo-20261122-120000-s0\n"
      "Ctrl-C writes a checkpoint and stops; --resume continues from it.");
  cmd->callback([o] {
    rl::TrainOptions to;
    to.command = command_line();
    to.stop_after_updates = o->stop_after;
    to.time_limit_s = o->time_limit;
    rl::TrainResult r;
    if (!o->resume.empty()) {
      if (!o->task.empty() || !o->overrides.empty() || !o->config.empty() || !o->run.empty())
        throw Error("--resume continues a run with its own config.yaml: drop --task, --config, "
                    "--run and -o");
      r = rl::train_resume(o->resume, to);
    } else {
      if (o->task.empty()) throw Error("train: --task is required (or --resume DIR)");
      tasks::find_task(o->task);  // unknown id: the error lists the known ones
      const std::string file = o->config.empty() ? rl::default_train_config(o->algo) : o->config;
      rl::default_train_config(o->algo);  // unknown algorithm: the error lists the known ones
      const std::string yaml = rl::resolve_train_yaml(file, o->algo, o->task, o->overrides);
      const rl::TrainConfig c = rl::parse_train_config(yaml, file);
      const std::string dir = o->run.empty() ? rl::default_run_dir(c) : o->run;
      r = rl::train_new(yaml, dir, to);
    }
    std::printf("run %s: %lld updates, %lld slot-steps; last mean return %s, success rate %s\n",
                r.run_dir.c_str(), static_cast<long long>(r.updates),
                static_cast<long long>(r.steps), num(r.last_return).c_str(),
                num(r.last_success, "%.3f").c_str());
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

void add_eval_command(CLI::App& app) {
  struct Opts {
    std::string run, checkpoint, json;
    int episodes = 100, threads = 0;
    uint64_t seed = 12345;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "eval", "Evaluate a trained policy (its mean action): mean return and success rate over "
              "episodes");
  cmd->add_option("--run", o->run, "Run folder of bidex train")->required();
  cmd->add_option("--checkpoint", o->checkpoint, "Checkpoint file (default: the run's newest)");
  cmd->add_option("--episodes", o->episodes, "Episodes (one per parallel slot)")
      ->check(CLI::Range(1, 100000))->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the evaluation episodes")->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads (0: all cores)");
  cmd->add_option("--json", o->json, "Also write the result as JSON to this file");
  cmd->footer("Example:\n  bidex eval --run runs/hand_over-ppo-20261122-120000-s0 --episodes 200");
  cmd->callback([o] {
    rl::LoadedPolicy policy(o->run, o->checkpoint);
    const rl::EvalResult r = rl::evaluate(policy, o->episodes, o->seed, o->threads);
    std::printf("%s, checkpoint %s (update %lld): %d episodes, mean return %s (std %s), "
                "success rate %.3f, mean length %.1f, faults %lld\n",
                policy.config().task.c_str(), policy.checkpoint().c_str(),
                static_cast<long long>(policy.update()), r.episodes, num(r.mean_return).c_str(),
                num(r.std_return).c_str(), r.success_rate, r.mean_length,
                static_cast<long long>(r.faults));
    if (!o->json.empty()) {
      nlohmann::json j = {{"run", o->run},
                          {"task", policy.config().task},
                          {"checkpoint", policy.checkpoint()},
                          {"update", policy.update()},
                          {"episodes", r.episodes},
                          {"mean_return", r.mean_return},
                          {"std_return", r.std_return},
                          {"success_rate", r.success_rate},
                          {"mean_length", r.mean_length},
                          {"faults", r.faults},
                          {"seed", o->seed},
                          {"command", command_line()}};
      write_file_atomic(o->json, j.dump(2) + "\n");
    }
  });
}

}  // namespace bidex::apps
