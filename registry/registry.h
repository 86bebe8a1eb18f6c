// The registry: one SQLite file of tasks ordered by human age, suites, training runs and
// reference scores (registry/README.md). Versioned schema with migrations, WAL mode; several
// processes may write at once (each write is one transaction that waits for the lock).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

struct sqlite3;

namespace bidex::registry {

// The current schema version (PRAGMA user_version); opening an older file migrates it.
int schema_version();

// The SQL of the migration step from version to_version - 1 to to_version (1..schema_version()).
// A new file runs every step in order from version 0 (registry/README.md lists them).
std::string migration_sql(int to_version);

// The reference scores loaded on open: $BIDEX_REFERENCES when set, else
// configs/registry/references.yaml under sim::data_dir().
std::string references_path();
// The sweep's time to each task's goal, loaded on open: $BIDEX_TIME_TO_GOAL when set, else
// configs/registry/time_to_goal.yaml under sim::data_dir(); a missing file is skipped.
std::string time_to_goal_path();

// --registry PATH, else $BIDEX_REGISTRY, else runs/registry.sqlite (relative to the working
// directory, beside the default run folders).
std::string default_path();

struct TaskRecord {
  std::string id;
  int version = 1;
  std::string paper_name, original_name;
  int age_min = 0, age_max = 0;       // months
  std::string age_text;               // as the paper writes it
  std::string difficulty;             // easy | medium | hard
  std::string skill;
  int obs_dim = 0, act_dim = 0;
  std::string origin;                 // "builtin", "variant" (of the task in sources["variant_of"],
                                      // e.g. MT4's hand_over_free) or the YAML file it was added from
  std::map<std::string, std::string> sources;  // fact (age, difficulty, ...) -> where it comes from
};

struct SuiteRecord {
  std::string id, mode, file, description;
  struct Member {
    std::string label, task, split;   // split: train | test
    double reward_scale = 1.0;
  };
  std::vector<Member> members;
};

struct RunRecord {
  int64_t id = 0;                     // assigned by begin_run
  std::string algo;
  std::string task;                   // a task id, or empty for a suite run
  std::string suite;                  // a suite id, or empty
  uint64_t seed = 0;
  int64_t steps = 0;                  // slot-steps trained so far
  std::string config_hash, code_version, run_dir, host;
  std::string started, finished;      // UTC ISO-8601; finished empty while running
  std::string status;                 // running | finished | stopped | failed
  std::optional<double> final_return, final_success;
  std::string dataset;                // an offline run: its dataset's checksum (datasets), else empty
};

// A dataset an offline run learned from, or bidex collect wrote (offline/dataset.h).
struct DatasetRecord {
  std::string checksum;               // "sha256:" + hex of its main_data.hdf5: the key
  std::string dataset_id, task, quality, path;
  int64_t total_steps = 0, total_episodes = 0;
  std::optional<double> ref_min, ref_max;  // the random and the expert return (0 and 100)
  std::string policy, code_version;
  std::string added;                  // UTC ISO-8601; empty: now
};

// Mean return and success of one task (a suite run has one per member, a task run one).
struct TaskScore {
  std::string task;                   // task id (for suite members: the member's task)
  std::string label;                  // suite member label, or the task id
  double mean_return = 0;
  std::optional<double> success;
  int64_t episodes = 0;
};

// One task's scores in a meta-RL evaluation: before adaptation (the first episode of each slot,
// the pre-adaptation policy) and after it.
struct AdaptScore {
  std::string task;                   // task id
  std::string label;                  // the suite member's label (empty: the task id)
  double return_before = 0, return_after = 0;
  std::optional<double> success_before, success_after;
  int64_t episodes = 0;               // evaluation slots of this task
};

// The normalised scores of a meta-RL evaluation's entries (Registry::normalised_scores), one per
// AdaptScore, and their means over the `count` entries whose task has both references (empty
// when none has).
struct AdaptNormalised {
  std::vector<std::optional<double>> before, after;
  std::optional<double> mean_before, mean_after;
  int count = 0;
};

// A meta-RL evaluation of a run on one split of its suite (`bidex eval --run DIR --split ...`).
struct Evaluation {
  int64_t id = 0;                     // assigned by add_evaluation
  int64_t run_id = 0;                 // the evaluated run (runs.id); must exist
  std::string split;                  // train | test
  int adapt_episodes = 0, adapt_steps = 0;
  uint64_t seed = 0;
  std::string checkpoint;             // the checkpoint file evaluated
  std::string time;                   // UTC ISO-8601; empty: now
  std::vector<AdaptScore> scores;
};

// A task's time to its goal in the PPO sweep (configs/registry/time_to_goal.yaml, made by
// bench/sweep_time_to_goal.py): goal "original_final" (training return at or above the
// original's published PPO final, `target`) or "success" (training success at or above
// `target`); reached_by "training" (the first update that met it), "evaluation" (the final mean
// action met it, training did not: an upper bound at the last update) or "not_reached" (no
// slot_steps; `trained` is a lower bound).
struct TimeToGoal {
  std::string task, goal;
  double target = 0;
  std::string reached_by;
  std::optional<double> slot_steps, wall_s;
  double trained = 0;                 // slot-steps the run trained
  std::string run, code_version, source;
};

struct Reference {
  std::string task;
  std::string kind;                   // random | ground_truth
  double value = 0;
  std::string source;
};

class Registry {
 public:
  // Opens or creates the file (its folder too); migrates an older schema; WAL mode.
  explicit Registry(const std::string& path);
  ~Registry();
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;
  const std::string& path() const { return path_; }

  // Every registered task but the variants: by age (age_min, then age_max, then id), else in
  // registration order (the built-in tasks in the paper's order first).
  std::vector<TaskRecord> tasks(bool by_age) const;
  // Any registered task, a variant too.
  std::optional<TaskRecord> task(const std::string& id) const;
  // Registers a task; an id already registered is an Error naming it.
  void add_task(const TaskRecord& t);

  std::vector<SuiteRecord> suites() const;
  void put_suite(const SuiteRecord& s);  // insert or replace

  // Records a new run (status running) and returns its id. An empty `started` becomes the
  // current UTC time, an empty `host` this machine's host name.
  int64_t begin_run(const RunRecord& r);
  // Updates the run's steps, status, finished time and final metrics, and replaces its scores.
  // An empty status becomes "finished", an empty `finished` the current UTC time.
  void finish_run(int64_t id, const RunRecord& r, const std::vector<TaskScore>& scores);
  std::vector<RunRecord> runs() const;          // by id
  std::optional<RunRecord> run(int64_t id) const;
  std::vector<TaskScore> scores(int64_t run_id) const;  // in the order finish_run got them
  // The newest run (highest id) whose run_dir is exactly `run_dir`.
  std::optional<RunRecord> run_by_dir(const std::string& run_dir) const;

  // Records a meta-RL evaluation with its scores in one transaction and returns its id. An
  // unknown run_id, a split other than train or test, negative adaptation counts, a non-finite
  // return or two scores with one label (an empty label is the task id) are an Error naming the
  // value; nothing is written then. An empty `time` becomes the current UTC time.
  int64_t add_evaluation(const Evaluation& e);
  // All evaluations (run_id 0) or those of one run, by id, each with its scores in the order
  // add_evaluation got them.
  std::vector<Evaluation> evaluations(int64_t run_id = 0) const;
  std::optional<Evaluation> evaluation(int64_t id) const;

  // Records a dataset (insert, or replace the row of the same checksum: its path, say). A
  // checksum that is not "sha256:..." or an empty task is an Error.
  void put_dataset(const DatasetRecord& d);
  std::vector<DatasetRecord> datasets() const;  // by task, quality, then time added
  std::optional<DatasetRecord> dataset(const std::string& checksum) const;
  // The offline normalised score of a return on a dataset, as the paper's table: 100 x (return -
  // ref_min) / (ref_max - ref_min), with the dataset's references, or where it has none (a
  // replay dataset) those of the newest dataset of its task that has both; empty when none does.
  std::optional<double> offline_normalised(const std::string& checksum, double mean_return) const;

  void set_reference(const Reference& r);  // insert or replace (task, kind)
  std::vector<Reference> references() const;    // by task, then kind
  std::optional<Reference> reference(const std::string& task, const std::string& kind) const;
  // The PPO sweep's time to each task's goal, by task (loaded on open).
  std::vector<TimeToGoal> time_to_goal() const;
  // (return - random) / (ground truth - random); empty when a reference is missing.
  std::optional<double> normalised(const std::string& task, double mean_return) const;
  // Each score's normalised return before and after adaptation, and their means.
  AdaptNormalised normalised_scores(const std::vector<AdaptScore>& scores) const;

 private:
  // Brings the suites table up to date with configs/suites (the suites taskpack knows).
  void sync_suites();

  std::string path_;
  sqlite3* db_ = nullptr;
};

}  // namespace bidex::registry
