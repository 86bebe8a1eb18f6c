#include "registry/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "core/error.h"
#include "core/plot.h"
#include "registry/sql.h"

namespace bidex::registry {

namespace {

std::string num(const std::optional<double>& v, const char* f = "%.4g") {
  if (!v || !std::isfinite(*v)) return "-";
  char buf[48];
  std::snprintf(buf, sizeof buf, f, *v);
  return buf;
}

// A row of `task` with its registry facts and references (no score yet).
AgeRow blank_row(const Registry& reg, const std::string& task, const std::string& label) {
  AgeRow row;
  row.task = task;
  row.label = label.empty() ? task : label;
  if (auto t = reg.task(task)) {
    row.registered = true;
    row.age_min = t->age_min;
    row.age_max = t->age_max;
    row.age_text = t->age_text;
    row.difficulty = t->difficulty;
  }
  if (auto r = reg.reference(task, "random")) row.random = r->value;
  if (auto r = reg.reference(task, "ground_truth")) row.ground_truth = r->value;
  return row;
}

void set_score(const Registry& reg, AgeRow& row, int64_t run, const TaskScore& s) {
  row.run = run;
  row.mean_return = s.mean_return;
  row.success = s.success;
  row.normalised = reg.normalised(row.task, s.mean_return);
}

// Rows of scores that come from run `run`.
std::vector<AgeRow> score_rows(const Registry& reg, int64_t run,
                               const std::vector<TaskScore>& scores) {
  std::vector<AgeRow> rows;
  for (auto& s : scores) {
    AgeRow row = blank_row(reg, s.task, s.label);
    set_score(reg, row, run, s);
    rows.push_back(std::move(row));
  }
  return rows;
}

// Rows of one run's scores.
std::vector<AgeRow> run_rows(const Registry& reg, const RunRecord& run) {
  return score_rows(reg, run.id, effective_scores(reg, run));
}

std::string counted(int n, const char* one, const char* many) {
  return sql::cat(std::to_string(n), " ", n == 1 ? one : many);
}

// Age order; tasks the registry does not know (variants) last.
void sort_by_age(std::vector<AgeRow>& rows) {
  std::stable_sort(rows.begin(), rows.end(), [](const AgeRow& a, const AgeRow& b) {
    if (a.registered != b.registered) return a.registered;
    if (a.age_min != b.age_min) return a.age_min < b.age_min;
    if (a.age_max != b.age_max) return a.age_max < b.age_max;
    if (a.task != b.task) return a.task < b.task;
    return a.label < b.label;
  });
}

std::string pad(const std::string& s, size_t w) {
  std::string out = s;
  if (out.size() < w) out.append(w - out.size(), ' ');
  return out;
}

}  // namespace

std::vector<TaskScore> effective_scores(const Registry& reg, const RunRecord& run) {
  std::vector<TaskScore> s = reg.scores(run.id);
  if (s.empty() && !run.task.empty() && run.final_return)
    s.push_back({run.task, run.task, *run.final_return, run.final_success, 0});
  return s;
}

AgeReport age_report(const Registry& reg, const std::string& suite, int64_t run) {
  AgeReport rep;
  if (run > 0) {
    const auto r = reg.run(run);
    if (!r) throw Error(sql::cat(reg.path(), ": no run with id ", std::to_string(run)));
    // a run that has been evaluated: its newest evaluation on the test split (else on the train
    // split), after adaptation (a run that does not adapt: its mean action's, bidex eval --run)
    const auto evals = reg.evaluations(run);
    for (const std::string split : {"test", "train"})
      for (auto it = evals.rbegin(); it != evals.rend(); ++it)
        if (it->split == split) return age_report_evaluation(reg, it->id);
    rep.rows = run_rows(reg, *r);
    if (rep.rows.empty())
      throw Error(sql::cat(reg.path(), ": run ", std::to_string(run),
                           " recorded no scores (status ", r->status, ")"));
    rep.source = sql::cat("run ", std::to_string(run), " (", r->algo, ", ",
                          r->task.empty() ? "suite " + r->suite : r->task, ")");
  } else if (!suite.empty()) {
    const auto runs = reg.runs();
    for (auto it = runs.rbegin(); it != runs.rend() && rep.rows.empty(); ++it)
      if (it->suite == suite) {
        rep.rows = run_rows(reg, *it);
        rep.source = sql::cat("suite ", suite, ", its latest scored run ", std::to_string(it->id),
                              " (", it->algo, ")");
      }
    if (rep.rows.empty())
      throw Error(sql::cat(reg.path(), ": no run of suite '", suite, "' recorded scores"));
  } else {
    // every registered task, with the latest run that scored it (newest run id first); within
    // a run that scored a task under several labels, the label equal to the task id, else the
    // first
    std::map<std::string, AgeRow> latest;
    const auto runs = reg.runs();
    for (auto it = runs.rbegin(); it != runs.rend(); ++it)
      for (auto& s : effective_scores(reg, *it)) {
        auto found = latest.find(s.task);
        if (found != latest.end() &&
            (found->second.run != it->id || found->second.label == s.task || s.label != s.task))
          continue;
        AgeRow row = blank_row(reg, s.task, s.label);
        set_score(reg, row, it->id, s);
        latest[s.task] = std::move(row);
      }
    for (auto& t : reg.tasks(true)) {
      auto found = latest.find(t.id);
      rep.rows.push_back(found != latest.end() ? found->second : blank_row(reg, t.id, t.id));
    }
    rep.source = "the latest scored run of each task";
  }
  sort_by_age(rep.rows);
  return rep;
}

std::string adaptation_text(const Evaluation& e) {
  if (e.adapt_episodes == 0) return "the mean action, no adaptation";
  return sql::cat("after ", counted(e.adapt_episodes, "adaptation episode", "adaptation episodes"),
                  " and ", counted(e.adapt_steps, "gradient step", "gradient steps"));
}

AgeReport age_report_evaluation(const Registry& reg, int64_t evaluation_id) {
  const auto e = reg.evaluation(evaluation_id);
  if (!e)
    throw Error(sql::cat(reg.path(), ": no evaluation with id ", std::to_string(evaluation_id),
                         " (bidex registry evals)"));
  if (e->scores.empty())
    throw Error(sql::cat(reg.path(), ": evaluation ", std::to_string(evaluation_id),
                         " recorded no scores"));
  std::vector<TaskScore> after;
  for (auto& s : e->scores)
    after.push_back({s.task, s.label, s.return_after, s.success_after, s.episodes});
  AgeReport rep;
  rep.rows = score_rows(reg, e->run_id, after);
  const auto run = reg.run(e->run_id);  // always there: add_evaluation checks it
  const std::string what =
      run ? sql::cat(run->algo, " on ", run->task.empty() ? run->suite : run->task) : "?";
  rep.source = sql::cat("evaluation ", std::to_string(e->id), " of run ", std::to_string(e->run_id),
                        " (", what, ", split ", e->split, ", ", adaptation_text(*e), ")");
  sort_by_age(rep.rows);
  return rep;
}

std::vector<std::string> unplotted(const AgeReport& report) {
  std::vector<std::string> out;
  for (auto& r : report.rows)
    if (!r.normalised || !r.registered) out.push_back(r.label);
  return out;
}

std::string age_table(const AgeReport& report) {
  size_t w = 4;
  for (auto& r : report.rows) w = std::max(w, r.label.size());
  std::string s = sql::cat("scores of ", report.source, "; normalised = (return - random) / "
                           "(ground truth - random)\n");
  const char* const f = "%-7s %-10s  %-6s %9s  %9s  %12s  %10s\n";
  char head[256];
  std::snprintf(head, sizeof head, f, "age", "difficulty", "run", "return", "random",
                "ground_truth", "normalised");
  s.append(pad("task", w + 2)).append(head);
  for (auto& r : report.rows) {
    char buf[256];
    std::snprintf(buf, sizeof buf, f,
                  r.registered ? r.age_text.c_str() : "?",
                  r.registered ? r.difficulty.c_str() : "?",
                  r.run > 0 ? std::to_string(r.run).c_str() : "-", num(r.mean_return).c_str(),
                  num(r.random).c_str(), num(r.ground_truth).c_str(),
                  num(r.normalised, "%.3f").c_str());
    s.append(pad(r.label, w + 2)).append(buf);
  }
  return s;
}

std::vector<GoalRow> goal_rows(const Registry& reg) {
  std::map<std::string, TimeToGoal> by_task;
  for (auto& g : reg.time_to_goal()) by_task[g.task] = g;
  std::vector<GoalRow> rows;
  for (auto& t : reg.tasks(true)) {  // by age
    const auto g = by_task.find(t.id);
    if (g == by_task.end()) continue;
    rows.push_back({t.id, t.age_text, t.age_min, t.age_max, g->second});
  }
  return rows;
}

std::string goal_table(const std::vector<GoalRow>& rows) {
  if (rows.empty()) return "";
  size_t w = 4;
  for (auto& r : rows) w = std::max(w, r.task.size());
  std::string s = sql::cat(
      "the PPO sweep's time to each task's goal (", rows[0].goal.source,
      "): original_final = the training return at or above the original's published final, "
      "success = training success at or above the target; by training: the first update that "
      "met it, evaluation: only the final mean action met it (at most this), not_reached: not "
      "met in the slot-steps trained\n");
  const char* const f = "%-7s %-15s %8s  %11s  %8s  %-12s %9s\n";
  char head[256];
  std::snprintf(head, sizeof head, f, "age", "goal", "target", "slot-steps", "wall_s", "by",
                "trained");
  s.append(pad("task", w + 2)).append(head);
  for (auto& r : rows) {
    const auto& g = r.goal;
    const std::optional<double> m =
        g.slot_steps ? std::optional<double>(*g.slot_steps / 1e6) : std::nullopt;
    char buf[256];
    std::snprintf(buf, sizeof buf, f, r.age_text.c_str(), g.goal.c_str(),
                  num(g.target).c_str(), (m ? num(m, "%.1fM") : std::string("-")).c_str(),
                  num(g.wall_s, "%.0f").c_str(), g.reached_by.c_str(),
                  num(g.trained / 1e6, "%.1fM").c_str());
    s.append(pad(r.task, w + 2)).append(buf);
  }
  return s;
}

std::string age_svg(const AgeReport& report, const std::vector<GoalRow>& goals) {
  plot::Series pts;
  pts.points = true;
  for (auto& r : report.rows)
    if (r.registered && r.normalised) {
      pts.x.push_back(r.age_months());
      pts.y.push_back(*r.normalised);
      pts.labels.push_back(r.label);
    }
  plot::Panel p;
  p.title = sql::cat("Normalised score against human age: ", report.source);
  p.xlabel = "human age at which the skill appears (months, log scale; a range at its middle)";
  p.ylabel = "normalised score (0 random, 1 ground truth)";
  p.xlog = true;
  p.xpad = 0.06;
  p.series.push_back(std::move(pts));
  // the two reference levels across the ages of every row, drawn as lines
  double lo = INFINITY, hi = -INFINITY;
  for (auto& r : report.rows)
    if (r.registered) {
      lo = std::min(lo, r.age_months());
      hi = std::max(hi, r.age_months());
    }
  if (std::isfinite(lo) && !p.series[0].x.empty())
    for (double level : {0.0, 1.0}) {
      plot::Series line;
      line.x = {lo, hi};
      line.y = {level, level};
      p.series.push_back(std::move(line));
    }
  const auto left_out = unplotted(report);
  if (!left_out.empty()) {
    std::string note = "left out, no normalised score: ";
    for (size_t i = 0; i < left_out.size(); ++i)
      note.append(i ? ", " : "").append(left_out[i]);
    p.note = note;
  }
  if (goals.empty()) return plot::svg({p}, 900, 480);
  // the sweep's slot-steps to each goal (millions), one series per kind of result
  plot::Panel g;
  g.title = "PPO sweep: slot-steps to each task's goal against human age";
  g.xlabel = p.xlabel;
  g.ylabel = "slot-steps to the goal (millions)";
  g.xlog = true;
  g.xpad = 0.06;
  const std::pair<const char*, const char*> kinds[] = {
      {"training", "met in training (first update)"},
      {"evaluation", "met by the final mean action only (at most)"},
      {"not_reached", "not met (at least: the slot-steps trained)"}};
  for (auto& [by, name] : kinds) {
    plot::Series pts;
    pts.points = true;
    pts.name = name;
    for (auto& r : goals)
      if (r.goal.reached_by == by) {
        pts.x.push_back(r.age_months());
        pts.y.push_back((r.goal.slot_steps ? *r.goal.slot_steps : r.goal.trained) / 1e6);
        pts.labels.push_back(r.task);
      }
    if (!pts.x.empty()) g.series.push_back(std::move(pts));
  }
  return plot::svg({p, g}, 900, 480);
}

}  // namespace bidex::registry
