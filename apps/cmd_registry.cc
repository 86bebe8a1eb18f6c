// bidex registry list | add-task | scores | evals | reference | report age: the SQLite registry
// of tasks ordered by human age, training runs, meta-RL evaluations and reference scores
// (registry/README.md).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "apps/commands.h"
#include "apps/programs.h"
#include "core/error.h"
#include "core/files.h"
#include "registry/registry.h"
#include "registry/report.h"
#include "registry/task_file.h"

namespace bidex::apps {

namespace {

using registry::Registry;

std::string num(const std::optional<double>& v, const char* f = "%.4g") {
  if (!v || !std::isfinite(*v)) return "-";
  char buf[48];
  std::snprintf(buf, sizeof buf, f, *v);
  return buf;
}

std::string in_quotes(const std::string& s) {
  std::string q = "'";
  q.append(s).append("'");
  return q;
}

// --registry PATH on every leaf command
void add_registry_option(CLI::App* cmd, std::string& path) {
  cmd->add_option("--registry", path,
                  "Registry file (default: $BIDEX_REGISTRY, else runs/registry.sqlite); created "
                  "with the built-in tasks when missing");
}
std::string registry_path(const std::string& given) {
  return given.empty() ? registry::default_path() : given;
}

// The folder of a file path ("." when it has none).
std::string folder_of(const std::string& path) {
  const size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

void print_tasks(const Registry& reg, bool by_age) {
  const auto tasks = reg.tasks(by_age);
  std::printf("%s: %zu tasks%s\n", reg.path().c_str(), tasks.size(),
              by_age ? ", by human age" : ", in registration order");
  size_t w = 2;
  for (auto& t : tasks) w = std::max(w, t.id.size());
  std::printf("%-*s  %-7s %-10s %5s %4s %10s %12s  %s\n", static_cast<int>(w), "id", "age",
              "difficulty", "obs", "act", "random", "ground_truth", "origin");
  auto ref = [&](const std::string& task, const char* kind) {
    const auto r = reg.reference(task, kind);
    return num(r ? std::optional<double>(r->value) : std::nullopt);
  };
  for (auto& t : tasks)
    std::printf("%-*s  %-7s %-10s %5d %4d %10s %12s  %s\n", static_cast<int>(w), t.id.c_str(),
                t.age_text.c_str(), t.difficulty.c_str(), t.obs_dim, t.act_dim,
                ref(t.id, "random").c_str(), ref(t.id, "ground_truth").c_str(), t.origin.c_str());
}

void print_run(const Registry& reg, const registry::RunRecord& r) {
  const std::string what = r.task.empty() ? "suite " + r.suite : r.task;
  std::printf("run %lld  %s  %s  seed %llu  %lld steps  %s", static_cast<long long>(r.id),
              r.algo.c_str(), what.c_str(), static_cast<unsigned long long>(r.seed),
              static_cast<long long>(r.steps), r.status.c_str());
  std::printf("  started %s", r.started.c_str());
  if (!r.finished.empty()) std::printf("  finished %s", r.finished.c_str());
  std::printf("  final return %s", num(r.final_return).c_str());
  if (!r.task.empty() && r.final_return)
    std::printf(" (normalised %s)", num(reg.normalised(r.task, *r.final_return), "%.3f").c_str());
  std::printf("  success %s\n", num(r.final_success, "%.3f").c_str());
  if (!r.run_dir.empty()) std::printf("  run folder %s\n", r.run_dir.c_str());
  const auto scores = reg.scores(r.id);
  if (scores.empty()) return;
  size_t w = 5;
  for (auto& s : scores) w = std::max(w, s.label.size());
  std::printf("  %-*s  %-20s %10s %8s %9s %11s\n", static_cast<int>(w), "label", "task", "return",
              "success", "episodes", "normalised");
  for (auto& s : scores)
    std::printf("  %-*s  %-20s %10s %8s %9lld %11s\n", static_cast<int>(w), s.label.c_str(),
                s.task.c_str(), num(s.mean_return).c_str(), num(s.success, "%.3f").c_str(),
                static_cast<long long>(s.episodes),
                num(reg.normalised(s.task, s.mean_return), "%.3f").c_str());
}

// One evaluation: what was evaluated, then per task its return and success before and after
// adaptation (a run that does not adapt: its mean action's, the same twice) and its normalised
// score after, then the mean of those normalised scores.
void print_evaluation(const Registry& reg, const registry::Evaluation& e) {
  const auto run = reg.run(e.run_id);
  std::string what = "?";
  if (run) {
    what = run->algo;
    what.append(", ").append(run->task.empty() ? "suite " + run->suite : run->task);
  }
  std::printf("evaluation %lld  run %lld (%s)  split %s  %s  seed %llu  %s\n",
              static_cast<long long>(e.id), static_cast<long long>(e.run_id), what.c_str(),
              e.split.c_str(), registry::adaptation_text(e).c_str(),
              static_cast<unsigned long long>(e.seed), e.time.c_str());
  if (!e.checkpoint.empty()) std::printf("  checkpoint %s\n", e.checkpoint.c_str());
  if (e.scores.empty()) return;
  size_t w = 5;
  for (auto& s : e.scores) w = std::max(w, s.label.size());
  std::printf("  %-*s  %-20s %22s  %24s %9s %11s\n", static_cast<int>(w), "label", "task",
              "return before -> after", "success before -> after", "episodes", "normalised");
  const registry::AdaptNormalised n = reg.normalised_scores(e.scores);
  for (size_t i = 0; i < e.scores.size(); ++i) {
    const auto& s = e.scores[i];
    std::printf("  %-*s  %-20s %9s -> %-9s  %10s -> %-10s %9lld %11s\n", static_cast<int>(w),
                s.label.c_str(), s.task.c_str(), num(s.return_before).c_str(),
                num(s.return_after).c_str(), num(s.success_before, "%.3f").c_str(),
                num(s.success_after, "%.3f").c_str(), static_cast<long long>(s.episodes),
                num(n.after[i], "%.3f").c_str());
  }
  const char* after = e.adapt_episodes > 0 ? " after adaptation" : "";
  if (n.count > 0)
    std::printf("  mean normalised score%s: %.3f (%d of %zu tasks)\n", after, *n.mean_after,
                n.count, e.scores.size());
  else
    std::printf("  mean normalised score%s: - (no task has both references)\n", after);
}

}  // namespace

void add_registry_command(CLI::App& app) {
  auto* reg = app.add_subcommand(
      "registry", "The registry (one SQLite file): tasks ordered by human age, training runs, "
                  "reference scores and the age report");
  reg->require_subcommand(1);
  reg->footer(
      "The file: --registry PATH, else $BIDEX_REGISTRY, else runs/registry.sqlite. "
      "See registry/README.md.");

  // list
  {
    struct Opts {
      std::string registry, by;
    };
    auto o = std::make_shared<Opts>();
    auto* cmd = reg->add_subcommand(
        "list", "The registered tasks: id, human age, difficulty, observation and action "
                "widths, reference scores (a random policy's return and the ground truth, '-' "
                "where there is none), origin (builtin or the YAML file it was added from)");
    add_registry_option(cmd, o->registry);
    cmd->add_option("--by", o->by,
                    "Order: 'age' (age_min, then age_max, then id); left out: registration "
                    "order, the paper's first");
    cmd->footer("Example:\n  bidex registry list --by age");
    cmd->callback([o] {
      if (!o->by.empty() && o->by != "age")
        throw Error(std::string("registry list: --by takes 'age', not ").append(in_quotes(o->by)));
      Registry r(registry_path(o->registry));
      print_tasks(r, o->by == "age");
    });
  }

  // add-task
  {
    struct Opts {
      std::string registry, file;
    };
    auto o = std::make_shared<Opts>();
    auto* cmd = reg->add_subcommand(
        "add-task", "Register a task from a task description YAML (id, version, paper_name, "
                    "original_name, age {min, max, text}, difficulty, skill, obs_dim, act_dim, "
                    "sources); checked strictly, nothing is written when it has an error");
    add_registry_option(cmd, o->registry);
    cmd->add_option("file", o->file, "Task description YAML");
    cmd->footer("Example:\n  bidex registry add-task configs/registry/example_task.yaml");
    cmd->callback([o] {
      if (o->file.empty())
        throw Error("registry add-task: give the task description YAML (e.g. "
                    "configs/registry/example_task.yaml)");
      const registry::TaskRecord t = registry::load_task_file(o->file);
      Registry r(registry_path(o->registry));
      if (auto old = r.task(t.id))
        throw ConfigError(o->file, "id", "an id not registered yet",
                          in_quotes(t.id).append(", already registered (origin ")
                              .append(old->origin)
                              .append(")"));
      r.add_task(t);
      std::printf("registered %s (age %s months, %s, obs %d, act %d) in %s\n", t.id.c_str(),
                  t.age_text.c_str(), t.difficulty.c_str(), t.obs_dim, t.act_dim,
                  r.path().c_str());
    });
  }

  // scores
  {
    struct Opts {
      std::string registry, task, suite;
    };
    auto o = std::make_shared<Opts>();
    auto* cmd = reg->add_subcommand(
        "scores", "Recorded runs with their final return and success, their per-task scores "
                  "and normalised scores ((return - random) / (ground truth - random))");
    add_registry_option(cmd, o->registry);
    cmd->add_option("--task", o->task, "Only runs of this task, or with a score of it");
    cmd->add_option("--suite", o->suite, "Only runs of this suite");
    cmd->footer("Examples:\n  bidex registry scores\n  bidex registry scores --task hand_over");
    cmd->callback([o] {
      Registry r(registry_path(o->registry));
      int shown = 0;
      for (auto& run : r.runs()) {
        if (!o->suite.empty() && run.suite != o->suite) continue;
        if (!o->task.empty() && run.task != o->task) {
          bool scored = false;
          for (auto& s : r.scores(run.id)) scored = scored || s.task == o->task;
          if (!scored) continue;
        }
        print_run(r, run);
        ++shown;
      }
      std::printf("%d run%s in %s\n", shown, shown == 1 ? "" : "s", r.path().c_str());
    });
  }

  // offline
  {
    struct Opts {
      std::string registry, task;
    };
    auto o = std::make_shared<Opts>();
    auto* cmd = reg->add_subcommand(
        "offline", "Offline RL: the recorded datasets (checksum, quality, size, reference "
                   "scores) and every offline run on them with its final return and normalised "
                   "score (random 0, online PPO 100, as the paper's table)");
    add_registry_option(cmd, o->registry);
    cmd->add_option("--task", o->task, "Only datasets and runs of this task");
    cmd->footer("Example:\n  bidex registry offline --task hand_over");
    cmd->callback([o] {
      Registry r(registry_path(o->registry));
      auto num = [](const std::optional<double>& v, const char* f) {
        if (!v) return std::string("-");
        char b[32];
        std::snprintf(b, sizeof b, f, *v);
        return std::string(b);
      };
      int shown = 0;
      for (auto& d : r.datasets()) {
        if (!o->task.empty() && d.task != o->task) continue;
        std::printf("%-20s %-14s %9lld steps %7lld episodes  random %s expert %s  %s\n",
                    d.task.c_str(), d.quality.c_str(), static_cast<long long>(d.total_steps),
                    static_cast<long long>(d.total_episodes), num(d.ref_min, "%.4g").c_str(),
                    num(d.ref_max, "%.4g").c_str(), d.checksum.substr(0, 19).c_str());
        for (auto& run : r.runs()) {
          if (run.dataset != d.checksum) continue;
          std::optional<double> norm;
          if (run.final_return) norm = r.offline_normalised(d.checksum, *run.final_return);
          std::printf("    run %-5lld %-6s seed %-4llu %9lld gradient steps  %-8s return %s  "
                      "normalised %s\n",
                      static_cast<long long>(run.id), run.algo.c_str(),
                      static_cast<unsigned long long>(run.seed),
                      static_cast<long long>(run.steps), run.status.c_str(),
                      num(run.final_return, "%.4g").c_str(), num(norm, "%.1f").c_str());
        }
        ++shown;
      }
      std::printf("%d dataset%s in %s\n", shown, shown == 1 ? "" : "s", r.path().c_str());
    });
  }

  // evals
  {
    struct Opts {
      std::string registry;
      int64_t run = 0;
    };
    auto o = std::make_shared<Opts>();
    auto* cmd = reg->add_subcommand(
        "evals", "Recorded evaluations (bidex eval --run DIR): per task the return and success "
                 "before and after adaptation (meta-RL runs, --split train|test; other runs: "
                 "their mean action's, no adaptation), the normalised score after it and their "
                 "mean");
    add_registry_option(cmd, o->registry);
    auto* run = cmd->add_option("--run", o->run, "Only evaluations of this run (id)");
    cmd->footer("Examples:\n  bidex registry evals\n  bidex registry evals --run 12");
    cmd->callback([o, run] {
      if (run->count() > 0 && o->run < 1)
        throw Error(std::string("registry evals: --run takes a run id >= 1, not ")
                        .append(std::to_string(o->run)));
      Registry r(registry_path(o->registry));
      if (run->count() > 0 && !r.run(o->run))
        throw Error(r.path() + ": no run with id " + std::to_string(o->run) +
                    " (bidex registry scores)");
      const auto evals = r.evaluations(o->run);
      for (auto& e : evals) print_evaluation(r, e);
      std::printf("%zu evaluation%s in %s\n", evals.size(), evals.size() == 1 ? "" : "s",
                  r.path().c_str());
    });
  }

  // reference
  {
    struct Opts {
      std::string registry, task, kind, source;
      double value = 0;
    };
    auto o = std::make_shared<Opts>();
    auto* cmd = reg->add_subcommand(
        "reference", "Set a task's reference score (random or ground_truth) with its source; "
                     "replaces the one recorded");
    add_registry_option(cmd, o->registry);
    cmd->add_option("--task", o->task, "Task id");
    cmd->add_option("--kind", o->kind, "random | ground_truth");
    auto* value = cmd->add_option("--value", o->value, "Mean episode return");
    cmd->add_option("--source", o->source, "Where the value comes from");
    cmd->footer(
        "Example (the value is illustrative, not a measurement):\n"
        "  bidex registry reference --task pen --kind ground_truth --value 120 "
        "--source \"my PPO run, runs/pen-ppo-s0, 100M steps\"\n"
        "A random policy's score is measured and stored by\n"
        "  bidex eval --random --task pen --episodes 256 --set-reference");
    cmd->callback([o, value] {
      std::string missing;
      if (o->task.empty()) missing.append(" --task");
      if (o->kind.empty()) missing.append(" --kind");
      if (value->count() == 0) missing.append(" --value");
      if (o->source.empty()) missing.append(" --source");
      if (!missing.empty()) throw Error("registry reference: missing" + missing);
      if (o->kind != "random" && o->kind != "ground_truth")
        throw Error(std::string("registry reference: --kind takes random or ground_truth, not ")
                        .append(in_quotes(o->kind)));
      Registry r(registry_path(o->registry));
      r.set_reference({o->task, o->kind, o->value, o->source});
      std::printf("%s %s = %s (%s) in %s\n", o->task.c_str(), o->kind.c_str(),
                  num(o->value, "%.6g").c_str(), o->source.c_str(), r.path().c_str());
    });
  }

  // report age
  {
    auto* report = reg->add_subcommand("report", "Reports over the registry");
    report->require_subcommand(1);
    struct Opts {
      std::string registry, suite, out;
      int64_t run = 0, eval = 0;
    };
    auto o = std::make_shared<Opts>();
    auto* cmd = report->add_subcommand(
        "age", "Each task's latest score in human-age order with its reference and normalised "
               "scores, as a table (printed, and a .txt file) and a plot of normalised score against "
               "human age (SVG, and PNG with rsvg-convert); below them, the PPO sweep's slot-steps "
               "to each task's goal against the same ages (configs/registry/time_to_goal.yaml)");
    add_registry_option(cmd, o->registry);
    cmd->add_option("--suite", o->suite, "Scores of the latest scored run of this suite");
    cmd->add_option("--run", o->run, "Scores of this run (id, see bidex registry scores)");
    auto* eval = cmd->add_option(
        "--eval", o->eval,
        "Scores of this evaluation, after adaptation for a meta-RL run's (id, see bidex registry "
        "evals)");
    cmd->add_option("--out", o->out,
                    "SVG file (default: age_report.svg beside the registry); the table goes beside "
                    "it as .txt, and the plot as .png when rsvg-convert is installed");
    cmd->footer(
        "Without --suite, --run or --eval, each task's score is that of the latest run that "
        "scored it.\n"
        "Examples:\n  bidex registry report age --out age_report.svg\n"
        "  bidex registry report age --eval 3 --out eval3_age.svg");
    cmd->callback([o, eval] {
      const bool by_eval = eval->count() > 0;
      if ((!o->suite.empty()) + (o->run != 0) + by_eval > 1)
        throw Error("registry report age: give one of --suite, --run and --eval, not several");
      if (o->run < 0) throw Error("registry report age: --run takes a run id >= 1");
      if (by_eval && o->eval < 1)
        throw Error(std::string("registry report age: --eval takes an evaluation id >= 1, not ")
                        .append(std::to_string(o->eval)));
      Registry r(registry_path(o->registry));
      const registry::AgeReport rep = by_eval ? registry::age_report_evaluation(r, o->eval)
                                              : registry::age_report(r, o->suite, o->run);
      std::string table = registry::age_table(rep);
      const auto left_out = registry::unplotted(rep);
      if (!left_out.empty()) {
        std::string list;
        for (auto& l : left_out) list.append(list.empty() ? "" : ", ").append(l);
        table += "left out of the plot (no normalised score): " + list + "\n";
      }
      // beside it, the PPO sweep's time to each task's goal (configs/registry/time_to_goal.yaml)
      const auto goals = registry::goal_rows(r);
      if (!goals.empty()) table += "\n" + registry::goal_table(goals);
      std::fputs(table.c_str(), stdout);
      const std::string out = o->out.empty() ? folder_of(r.path()) + "/age_report.svg" : o->out;
      write_file_atomic(out, registry::age_svg(rep, goals));
      std::printf("plot (%zu of %zu tasks): %s\n", rep.rows.size() - left_out.size(),
                  rep.rows.size(), out.c_str());
      // beside the plot: the table as text, and the plot as a PNG
      const std::string txt = without_svg(out) + ".txt";
      write_file_atomic(txt, table);
      std::printf("table: %s\n%s\n", txt.c_str(), png_beside(out).c_str());
    });
  }
}

}  // namespace bidex::apps
