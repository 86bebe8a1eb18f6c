// Reports over the registry: the latest score of each task in human-age order with its reference
// scores and normalised score (`bidex registry report age`), as a text table and an SVG plot of
// normalised score against human age, like the paper's age figure.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "registry/registry.h"

namespace bidex::registry {

// The scores a run contributes: its per-task scores, or, for a task run that recorded none, one
// score from its final return and success.
std::vector<TaskScore> effective_scores(const Registry& reg, const RunRecord& run);

struct AgeRow {
  std::string task, label;            // label: the suite member's label, else the task id
  bool registered = false;            // the task is in the registry (age and difficulty known)
  int age_min = 0, age_max = 0;       // months
  std::string age_text, difficulty;
  int64_t run = 0;                    // the run the score comes from; 0: no score
  std::optional<double> mean_return, success, random, ground_truth, normalised;
  double age_months() const { return 0.5 * (age_min + age_max); }  // the plot's x
};

struct AgeReport {
  std::string source;                 // where the scores come from, in words
  std::vector<AgeRow> rows;           // by age (age_min, age_max, task id, label)
};

// Which scores: those of `run` (> 0; a meta-RL run with evaluations: its newest test-split
// evaluation after adaptation, else its newest train-split one, as age_report_evaluation), else
// of the latest run of `suite` that recorded scores (non-empty), else for every registered task
// the latest run that scored it (its row empty when none has). An unknown run, or a suite
// without a scored run, is an Error.
AgeReport age_report(const Registry& reg, const std::string& suite = "", int64_t run = 0);

// The after-adaptation scores of meta-RL evaluation `evaluation_id` (Registry::add_evaluation):
// each task's return_after and success_after as its return and success, normalised with the
// registry's references like a run's; each row's run is the evaluated run. An unknown id, or an
// evaluation without scores, is an Error naming it.
AgeReport age_report_evaluation(const Registry& reg, int64_t evaluation_id);

// "after 1 adaptation episode and 2 gradient steps"
std::string adaptation_text(const Evaluation& e);

// The table as text (one line per row; "-" for a missing value).
std::string age_table(const AgeReport& report);
// The ids of the rows without a normalised score (left out of the plot).
std::vector<std::string> unplotted(const AgeReport& report);
// The PPO sweep's time to each task's goal (Registry::time_to_goal) beside the task's human age:
// the registered tasks that have one, in age order.
struct GoalRow {
  std::string task, age_text;
  int age_min = 0, age_max = 0;       // months
  TimeToGoal goal;
  double age_months() const { return 0.5 * (age_min + age_max); }
};
std::vector<GoalRow> goal_rows(const Registry& reg);
// Those rows as a text table (empty when there are none).
std::string goal_table(const std::vector<GoalRow>& rows);

// Normalised score against human age in months (log scale), one labelled point per row with a
// normalised score, in age order; with goal rows, a second panel below: the sweep's slot-steps
// to each task's goal against the same ages (met in training, met by the final mean action
// only: an upper bound, not met: a lower bound, each its own series).
std::string age_svg(const AgeReport& report, const std::vector<GoalRow>& goals = {});

}  // namespace bidex::registry
