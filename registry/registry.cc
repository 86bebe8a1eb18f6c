#include "registry/registry.h"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <map>
#include <set>
#include <thread>

#include <sys/stat.h>
#include <unistd.h>

#include "core/clock.h"
#include "core/error.h"
#include "core/yaml.h"
#include "registry/sql.h"
#include "sim/hand_spec.h"
#include "taskpack/suite.h"
#include "tasks/registry.h"

namespace bidex::registry {

namespace {

using sql::Stmt;
using sql::WriteTxn;

// The migration steps, in order: kMigrations[k] takes a file from version k to version k + 1.
// Never edit a released step: add a new one (and bump nothing else; schema_version() follows).
//
// Version 1: tasks, runs of single tasks with their final metrics, reference scores without
// sources.
// Version 2: where each task fact comes from (task_sources), suites and their members, runs of
// suites (runs.suite), per-task scores of a run (run_scores), the source of each reference score.
// Version 3: meta-RL evaluations of runs (evaluations) with each task's return and success before
// and after adaptation (evaluation_scores).
// Version 4: offline datasets (datasets: checksum, task, quality, reference scores) and the
// dataset an offline run learned from (runs.dataset, its checksum).
const char* const kMigrations[] = {
    // 0 -> 1
    R"sql(
CREATE TABLE tasks (
  id TEXT PRIMARY KEY,
  version INTEGER NOT NULL,
  paper_name TEXT NOT NULL,
  original_name TEXT NOT NULL DEFAULT '',
  age_min INTEGER NOT NULL,
  age_max INTEGER NOT NULL,
  age_text TEXT NOT NULL,
  difficulty TEXT NOT NULL CHECK (difficulty IN ('easy', 'medium', 'hard')),
  skill TEXT NOT NULL,
  obs_dim INTEGER NOT NULL,
  act_dim INTEGER NOT NULL,
  origin TEXT NOT NULL
);
CREATE TABLE runs (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  algo TEXT NOT NULL,
  task TEXT NOT NULL,
  seed INTEGER NOT NULL,
  steps INTEGER NOT NULL DEFAULT 0,
  config_hash TEXT NOT NULL DEFAULT '',
  code_version TEXT NOT NULL DEFAULT '',
  run_dir TEXT NOT NULL DEFAULT '',
  host TEXT NOT NULL DEFAULT '',
  started TEXT NOT NULL,
  finished TEXT NOT NULL DEFAULT '',
  status TEXT NOT NULL CHECK (status IN ('running', 'finished', 'stopped', 'failed')),
  final_return REAL,
  final_success REAL
);
CREATE TABLE reference_scores (
  task TEXT NOT NULL REFERENCES tasks(id),
  kind TEXT NOT NULL CHECK (kind IN ('random', 'ground_truth')),
  value REAL NOT NULL,
  PRIMARY KEY (task, kind)
);
CREATE INDEX runs_task ON runs(task);
)sql",
    // 1 -> 2
    R"sql(
ALTER TABLE runs ADD COLUMN suite TEXT NOT NULL DEFAULT '';
CREATE INDEX runs_suite ON runs(suite);
ALTER TABLE reference_scores ADD COLUMN source TEXT NOT NULL DEFAULT '';
UPDATE reference_scores SET source = 'unknown (recorded under registry schema version 1, which kept no sources)'
  WHERE source = '';
CREATE TABLE task_sources (
  task TEXT NOT NULL REFERENCES tasks(id),
  fact TEXT NOT NULL,
  source TEXT NOT NULL,
  PRIMARY KEY (task, fact)
);
CREATE TABLE suites (
  id TEXT PRIMARY KEY,
  mode TEXT NOT NULL,
  file TEXT NOT NULL DEFAULT '',
  description TEXT NOT NULL DEFAULT ''
);
CREATE TABLE suite_members (
  suite TEXT NOT NULL REFERENCES suites(id),
  split TEXT NOT NULL CHECK (split IN ('train', 'test')),
  label TEXT NOT NULL,
  task TEXT NOT NULL,
  reward_scale REAL NOT NULL DEFAULT 1,
  position INTEGER NOT NULL,
  PRIMARY KEY (suite, split, label)
);
CREATE TABLE run_scores (
  run INTEGER NOT NULL REFERENCES runs(id),
  label TEXT NOT NULL,
  task TEXT NOT NULL,
  mean_return REAL NOT NULL,
  success REAL,
  episodes INTEGER NOT NULL DEFAULT 0,
  position INTEGER NOT NULL,
  PRIMARY KEY (run, label)
);
CREATE INDEX run_scores_task ON run_scores(task);
)sql",
    // 2 -> 3
    R"sql(
CREATE TABLE evaluations (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  run INTEGER NOT NULL REFERENCES runs(id),
  split TEXT NOT NULL CHECK (split IN ('train', 'test')),
  adapt_episodes INTEGER NOT NULL,
  adapt_steps INTEGER NOT NULL,
  seed INTEGER NOT NULL,
  checkpoint TEXT NOT NULL DEFAULT '',
  time TEXT NOT NULL
);
CREATE INDEX evaluations_run ON evaluations(run);
CREATE TABLE evaluation_scores (
  evaluation INTEGER NOT NULL REFERENCES evaluations(id),
  label TEXT NOT NULL,
  task TEXT NOT NULL,
  return_before REAL NOT NULL,
  return_after REAL NOT NULL,
  success_before REAL,
  success_after REAL,
  episodes INTEGER NOT NULL DEFAULT 0,
  position INTEGER NOT NULL,
  PRIMARY KEY (evaluation, label)
);
)sql",
    // 3 -> 4
    R"sql(
CREATE TABLE datasets (
  checksum TEXT PRIMARY KEY,
  dataset_id TEXT NOT NULL,
  task TEXT NOT NULL,
  quality TEXT NOT NULL,
  path TEXT NOT NULL,
  total_steps INTEGER NOT NULL,
  total_episodes INTEGER NOT NULL,
  ref_min REAL,
  ref_max REAL,
  policy TEXT NOT NULL DEFAULT '',
  code_version TEXT NOT NULL DEFAULT '',
  added TEXT NOT NULL
);
CREATE INDEX datasets_task ON datasets(task);
ALTER TABLE runs ADD COLUMN dataset TEXT NOT NULL DEFAULT '';
)sql",
    // 4 -> 5
    R"sql(
CREATE TABLE time_to_goal (
  task TEXT PRIMARY KEY REFERENCES tasks(id),
  goal TEXT NOT NULL CHECK (goal IN ('original_final', 'success')),
  target REAL NOT NULL,
  reached_by TEXT NOT NULL CHECK (reached_by IN ('training', 'evaluation', 'not_reached')),
  slot_steps REAL,
  wall_s REAL,
  trained REAL NOT NULL,
  run TEXT NOT NULL DEFAULT '',
  code_version TEXT NOT NULL DEFAULT '',
  source TEXT NOT NULL DEFAULT ''
);
)sql",
};
constexpr int kVersion = static_cast<int>(sizeof kMigrations / sizeof *kMigrations);

// How long a write waits for another process's write lock.
constexpr int kBusyMs = 30000;

std::string in_quotes(const std::string& s) {
  std::string q = "'";
  q.append(s).append("'");
  return q;
}

std::string host_name() {
  char buf[256] = "";
  if (::gethostname(buf, sizeof buf - 1) != 0) return "";
  return buf;
}

// mkdir -p of the folder holding `path` (POSIX; the project uses no std::filesystem).
void make_parent_folders(const std::string& path) {
  for (size_t pos = path.find('/', 1); pos != std::string::npos; pos = path.find('/', pos + 1)) {
    const std::string dir = path.substr(0, pos);
    if (::mkdir(dir.c_str(), 0755) != 0 && errno != EEXIST) {
      std::string msg = path;
      msg.append(": cannot create folder ").append(dir).append(": ").append(std::strerror(errno));
      throw IoError(msg);
    }
  }
}

bool valid_difficulty(const std::string& d) {
  return d == "easy" || d == "medium" || d == "hard";
}
bool valid_kind(const std::string& k) { return k == "random" || k == "ground_truth"; }
bool valid_status(const std::string& s) {
  return s == "running" || s == "finished" || s == "stopped" || s == "failed";
}

int user_version(sqlite3* db, const std::string& path) {
  Stmt st(db, path, "PRAGMA user_version");
  return st.step() ? st.i32(0) : 0;
}

// Switches the file to WAL mode and returns the journal mode now in force. Changing the mode
// needs the file to itself: while another process holds a lock (two processes creating the file
// at once) SQLite answers "busy" at once, without its busy handler, so retry here for as long as
// the busy timeout.
std::string set_wal(sqlite3* db, const std::string& path) {
  const auto start = std::chrono::steady_clock::now();
  for (;;) {
    sqlite3_stmt* st = nullptr;
    int rc = sqlite3_prepare_v2(db, "PRAGMA journal_mode = WAL", -1, &st, nullptr);
    if (rc == SQLITE_OK) rc = sqlite3_step(st);
    std::string mode;
    if (rc == SQLITE_ROW) {
      const unsigned char* t = sqlite3_column_text(st, 0);
      mode = t ? reinterpret_cast<const char*>(t) : "";
    }
    sqlite3_finalize(st);
    if (rc == SQLITE_ROW) return mode;
    const bool busy = (rc & 0xff) == SQLITE_BUSY || (rc & 0xff) == SQLITE_LOCKED;
    if (!busy || std::chrono::steady_clock::now() - start > std::chrono::milliseconds(kBusyMs))
      sql::fail(db, path, "cannot switch the registry to WAL mode");
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

// The record of a built-in task, with the sources of its facts.
TaskRecord builtin_record(const tasks::TaskSpec& sp) {
  TaskRecord t;
  t.id = sp.id;
  t.version = sp.version;
  t.paper_name = sp.paper_name;
  t.original_name = sp.original_name;
  t.age_min = sp.age.min_months;
  t.age_max = sp.age.max_months;
  t.age_text = sp.age.text;
  t.difficulty = tasks::difficulty_name(sp.difficulty);
  t.skill = sp.skill;
  t.obs_dim = sp.obs.dim();
  t.act_dim = sp.act.dim();
  t.origin = sp.variant_of.empty() ? "builtin" : "variant";
  if (!sp.variant_of.empty()) t.sources["variant_of"] = sp.variant_of;
  const std::string table = sp.age.from_commented_row
                                ? "paper source, a commented-out row of the task table"
                                : "paper, task table";
  t.sources["age"] = table;
  t.sources["difficulty"] = table;
  t.sources["skill"] = table;
  t.sources["obs_dim"] = sp.id == "grasp_and_place" ? "original code; the paper gives no table"
                                                    : "paper, observation and action tables";
  t.sources["act_dim"] = "paper, observation and action tables";
  t.sources["names"] = "bidex task spec";
  t.sources["version"] = "bidex task spec";
  return t;
}

void upsert_task(sqlite3* db, const std::string& path, const TaskRecord& t) {
  Stmt st(db, path,
          "INSERT INTO tasks (id, version, paper_name, original_name, age_min, age_max, age_text, "
          "difficulty, skill, obs_dim, act_dim, origin) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, "
          "?9, ?10, ?11, ?12) ON CONFLICT (id) DO UPDATE SET version = ?2, paper_name = ?3, "
          "original_name = ?4, age_min = ?5, age_max = ?6, age_text = ?7, difficulty = ?8, "
          "skill = ?9, obs_dim = ?10, act_dim = ?11, origin = ?12");
  st.bind(1, t.id).bind(2, t.version).bind(3, t.paper_name).bind(4, t.original_name);
  st.bind(5, t.age_min).bind(6, t.age_max).bind(7, t.age_text).bind(8, t.difficulty);
  st.bind(9, t.skill).bind(10, t.obs_dim).bind(11, t.act_dim).bind(12, t.origin);
  st.run();
  Stmt src(db, path,
           "INSERT INTO task_sources (task, fact, source) VALUES (?1, ?2, ?3) "
           "ON CONFLICT (task, fact) DO UPDATE SET source = ?3");
  for (auto& [fact, text] : t.sources) {
    src.bind(1, t.id).bind(2, fact).bind(3, text);
    src.run();
    src.reset();
  }
}

bool task_exists(sqlite3* db, const std::string& path, const std::string& id) {
  Stmt st(db, path, "SELECT 1 FROM tasks WHERE id = ?1");
  st.bind(1, id);
  return st.step();
}

// Reference scores of configs/registry/references.yaml (sections ground_truth and random, each
// empty or {source, replaces?, values: {task: value or {value, source}}}). The file owns the rows
// whose source is one of its section's: the section's source, a value's own source, or one of
// `replaces` (the sources of the section's earlier editions). A value is inserted where the
// registry has none of that task and kind, and replaces a row the file owns; a row the file owns
// whose task the section no longer lists is withdrawn. Rows of any other source (a user's,
// `bidex registry reference`, `bidex eval --random --set-reference`) are never touched.
void load_references(sqlite3* db, const std::string& path) {
  const std::string file = references_path();
  const YamlView root = YamlView::load_file(file);
  if (root.node().IsNull()) return;
  root.allow_keys({"ground_truth", "random"});
  Stmt put(db, path,
           "INSERT INTO reference_scores (task, kind, value, source) VALUES (?1, ?2, ?3, ?4) "
           "ON CONFLICT (task, kind) DO UPDATE SET value = excluded.value, "
           "source = excluded.source");
  Stmt del(db, path, "DELETE FROM reference_scores WHERE task = ?1 AND kind = ?2");
  for (const char* kind : {"ground_truth", "random"}) {
    auto sec = root.maybe(kind);
    if (!sec || sec->node().IsNull()) continue;  // a section still to be measured
    sec->allow_keys({"source", "replaces", "values"});
    const std::string source = sec->req<std::string>("source");
    std::set<std::string> owned = {source};
    if (auto r = sec->maybe("replaces"))
      for (auto& old : r->as<std::vector<std::string>>()) owned.insert(old);
    std::map<std::string, std::pair<double, std::string>> listed;  // task -> value, source
    if (auto values = sec->maybe("values"); values && !values->node().IsNull()) {
      for (auto& task : values->keys()) {
        const YamlView v = values->child(task);
        if (!task_exists(db, path, task))
          v.fail("a registered task id", sql::cat("unknown task ", in_quotes(task)));
        double value = 0;
        std::string src = source;
        if (v.is_map()) {
          v.allow_keys({"value", "source"});
          value = v.req<double>("value");
          src = v.opt<std::string>("source", source);
        } else {
          value = v.as<double>();
        }
        owned.insert(src);
        listed[task] = {value, src};
      }
    }
    // the registry's rows of this kind: task -> source
    std::map<std::string, std::string> held;
    {
      Stmt all(db, path, "SELECT task, source FROM reference_scores WHERE kind = ?1");
      all.bind(1, kind);
      while (all.step()) held[all.text(0)] = all.text(1);
    }
    for (auto& [task, vs] : listed) {
      const auto h = held.find(task);
      if (h != held.end() && !owned.count(h->second)) continue;  // someone else's reference
      put.bind(1, task).bind(2, kind).bind(3, vs.first).bind(4, vs.second);
      put.run();
      put.reset();
    }
    for (auto& [task, src] : held) {  // withdrawn: rows the file made for tasks it no longer lists
      if (!owned.count(src) || listed.count(task)) continue;
      del.bind(1, task).bind(2, kind);
      del.run();
      del.reset();
    }
  }
}

// The PPO sweep's time to each task's goal, configs/registry/time_to_goal.yaml (made by
// bench/sweep_time_to_goal.py: {source, success_goal, values: {task: {goal, target, trained, run,
// commit, by, slot_steps, wall_s}}}). The file owns the table: its rows replace all others. A
// missing file leaves the table as it is.
void load_time_to_goal(sqlite3* db, const std::string& path) {
  const std::string file = time_to_goal_path();
  if (::access(file.c_str(), F_OK) != 0) return;
  const YamlView root = YamlView::load_file(file);
  if (root.node().IsNull()) return;
  root.allow_keys({"source", "success_goal", "values"});
  const std::string source = root.req<std::string>("source");
  sql::exec(db, path, "DELETE FROM time_to_goal");
  Stmt put(db, path,
           "INSERT INTO time_to_goal (task, goal, target, reached_by, slot_steps, wall_s, "
           "trained, run, code_version, source) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)");
  const auto values = root.child("values");
  for (auto& task : values.keys()) {
    const YamlView v = values.child(task);
    if (!task_exists(db, path, task))
      v.fail("a registered task id", sql::cat("unknown task ", in_quotes(task)));
    v.allow_keys({"goal", "target", "trained", "run", "commit", "by", "slot_steps", "wall_s"});
    const auto goal = v.req<std::string>("goal");
    if (goal != "original_final" && goal != "success")
      v.child("goal").fail("'original_final' or 'success'", goal);
    const auto by = v.req<std::string>("by");
    if (by != "training" && by != "evaluation" && by != "not_reached")
      v.child("by").fail("'training', 'evaluation' or 'not_reached'", by);
    // slot_steps and wall_s: numbers, or null where the goal was not reached
    auto maybe_number = [&](const char* key) -> std::optional<double> {
      const YamlView c = v.child(key);
      if (c.node().IsNull()) {
        if (by != "not_reached") c.fail("a number (the goal was reached)", "null");
        return std::nullopt;
      }
      return c.as<double>();
    };
    put.bind(1, task).bind(2, goal).bind(3, v.req<double>("target")).bind(4, by);
    put.bind(5, maybe_number("slot_steps")).bind(6, maybe_number("wall_s"));
    put.bind(7, v.req<double>("trained")).bind(8, v.req<std::string>("run"));
    put.bind(9, v.req<std::string>("commit")).bind(10, source);
    put.run();
    put.reset();
  }
}

TaskRecord read_task(const Stmt& st) {
  TaskRecord t;
  t.id = st.text(0);
  t.version = st.i32(1);
  t.paper_name = st.text(2);
  t.original_name = st.text(3);
  t.age_min = st.i32(4);
  t.age_max = st.i32(5);
  t.age_text = st.text(6);
  t.difficulty = st.text(7);
  t.skill = st.text(8);
  t.obs_dim = st.i32(9);
  t.act_dim = st.i32(10);
  t.origin = st.text(11);
  return t;
}
const char* const kTaskColumns =
    "SELECT id, version, paper_name, original_name, age_min, age_max, age_text, difficulty, "
    "skill, obs_dim, act_dim, origin FROM tasks ";

const char* const kRunColumns =
    "SELECT id, algo, task, suite, seed, steps, config_hash, code_version, run_dir, host, "
    "started, finished, status, final_return, final_success, dataset FROM runs ";
RunRecord read_run(const Stmt& st) {
  RunRecord r;
  r.id = st.i64(0);
  r.algo = st.text(1);
  r.task = st.text(2);
  r.suite = st.text(3);
  r.seed = static_cast<uint64_t>(st.i64(4));  // stored as the signed 64-bit pattern
  r.steps = st.i64(5);
  r.config_hash = st.text(6);
  r.code_version = st.text(7);
  r.run_dir = st.text(8);
  r.host = st.text(9);
  r.started = st.text(10);
  r.finished = st.text(11);
  r.status = st.text(12);
  r.final_return = st.opt(13);
  r.final_success = st.opt(14);
  r.dataset = st.text(15);
  return r;
}

const char* const kDatasetColumns =
    "SELECT checksum, dataset_id, task, quality, path, total_steps, total_episodes, ref_min, "
    "ref_max, policy, code_version, added FROM datasets ";
DatasetRecord read_dataset(const Stmt& st) {
  DatasetRecord d;
  d.checksum = st.text(0);
  d.dataset_id = st.text(1);
  d.task = st.text(2);
  d.quality = st.text(3);
  d.path = st.text(4);
  d.total_steps = st.i64(5);
  d.total_episodes = st.i64(6);
  d.ref_min = st.opt(7);
  d.ref_max = st.opt(8);
  d.policy = st.text(9);
  d.code_version = st.text(10);
  d.added = st.text(11);
  return d;
}

const char* const kEvaluationColumns =
    "SELECT id, run, split, adapt_episodes, adapt_steps, seed, checkpoint, time "
    "FROM evaluations ";
Evaluation read_evaluation(const Stmt& st) {
  Evaluation e;
  e.id = st.i64(0);
  e.run_id = st.i64(1);
  e.split = st.text(2);
  e.adapt_episodes = st.i32(3);
  e.adapt_steps = st.i32(4);
  e.seed = static_cast<uint64_t>(st.i64(5));  // stored as the signed 64-bit pattern
  e.checkpoint = st.text(6);
  e.time = st.text(7);
  return e;
}

// Appends the evaluation's scores, in the order add_evaluation got them.
void read_evaluation_scores(sqlite3* db, const std::string& path, Evaluation& e) {
  Stmt st(db, path,
          "SELECT task, label, return_before, return_after, success_before, success_after, "
          "episodes FROM evaluation_scores WHERE evaluation = ?1 ORDER BY position");
  st.bind(1, e.id);
  while (st.step())
    e.scores.push_back({st.text(0), st.text(1), st.dbl(2), st.dbl(3), st.opt(4), st.opt(5),
                        st.i64(6)});
}

// The label a score is stored under: its label, else its task id.
const std::string& label_of(const AdaptScore& s) { return s.label.empty() ? s.task : s.label; }

void check_task_record(const TaskRecord& t) {
  std::string what;
  if (t.id.empty()) what = "an empty id";
  else if (t.version < 1) what = sql::cat("version ", std::to_string(t.version), " (expected >= 1)");
  else if (t.age_min < 0 || t.age_max < t.age_min)
    what = sql::cat("age ", std::to_string(t.age_min), "..", std::to_string(t.age_max),
                    " months (expected 0 <= min <= max)");
  else if (!valid_difficulty(t.difficulty))
    what = sql::cat("difficulty ", in_quotes(t.difficulty), " (expected easy, medium or hard)");
  else if (t.obs_dim < 1 || t.act_dim < 1)
    what = sql::cat("dimensions obs ", std::to_string(t.obs_dim), ", act ",
                    std::to_string(t.act_dim), " (expected >= 1)");
  if (!what.empty()) {
    std::string msg = "task ";
    msg.append(in_quotes(t.id)).append(": ").append(what);
    throw Error(msg);
  }
}

}  // namespace

int schema_version() { return kVersion; }

std::string migration_sql(int to_version) {
  if (to_version < 1 || to_version > kVersion)
    throw Error(sql::cat("no registry migration to version ", std::to_string(to_version), " (1..",
                         std::to_string(kVersion), ")"));
  return kMigrations[to_version - 1];
}

std::string references_path() {
  if (const char* e = std::getenv("BIDEX_REFERENCES"); e && *e) return e;
  return sim::data_dir() + "/configs/registry/references.yaml";
}

std::string time_to_goal_path() {
  if (const char* e = std::getenv("BIDEX_TIME_TO_GOAL"); e && *e) return e;
  return sim::data_dir() + "/configs/registry/time_to_goal.yaml";
}

std::string default_path() {
  if (const char* env = std::getenv("BIDEX_REGISTRY"); env && *env) return env;
  return "runs/registry.sqlite";
}

Registry::Registry(const std::string& path) : path_(path) {
  if (path_.empty()) throw Error("registry: empty file name");
  make_parent_folders(path_);
  if (sqlite3_open_v2(path_.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) !=
      SQLITE_OK) {
    std::string msg = path_;
    msg.append(": cannot open the registry: ").append(db_ ? sqlite3_errmsg(db_) : "out of memory");
    sqlite3_close(db_);
    db_ = nullptr;
    throw IoError(msg);
  }
  try {
    sqlite3_busy_timeout(db_, kBusyMs);
    // the first read of the file tells an SQLite file from anything else
    {
      sqlite3_stmt* probe = nullptr;
      int rc = sqlite3_prepare_v2(db_, "SELECT count(*) FROM sqlite_master", -1, &probe, nullptr);
      if (rc == SQLITE_OK) rc = sqlite3_step(probe);
      sqlite3_finalize(probe);
      if (rc != SQLITE_ROW) {
        std::string msg = path_;
        msg.append(": not a bidex registry: cannot read it as an SQLite database (")
            .append(sqlite3_errmsg(db_))
            .append(")");
        throw Error(msg);
      }
    }
    const auto newer = [&](int v) {
      std::string msg = path_;
      msg.append(": registry schema version ")
          .append(std::to_string(v))
          .append(" is newer than this bidex knows (")
          .append(std::to_string(kVersion))
          .append("): open it with a newer bidex; the file was left untouched");
      return Error(msg);
    };
    // refuse a newer registry or another program's SQLite file before changing anything
    const auto foreign = [&]() -> std::optional<Error> {
      Stmt st(db_, path_, "SELECT name FROM sqlite_master WHERE type = 'table' LIMIT 1");
      if (!st.step()) return std::nullopt;
      std::string msg = path_;
      msg.append(": not a bidex registry: an SQLite file with other tables (")
          .append(st.text(0))
          .append(") and no registry schema version");
      return Error(msg);
    };
    const int found = user_version(db_, path_);
    if (found > kVersion) throw newer(found);
    if (found == 0) {
      if (auto e = foreign()) throw *e;
    }

    // WAL: readers never block the writer; the mode is stored in the file
    {
      const std::string mode = set_wal(db_, path_);
      if (mode != "wal") {
        std::string msg = path_;
        msg.append(": cannot switch the registry to WAL mode (journal mode is ")
            .append(in_quotes(mode))
            .append(")");
        throw Error(msg);
      }
    }
    sql::exec(db_, path_, "PRAGMA synchronous = NORMAL; PRAGMA foreign_keys = ON");

    // migrate, then bring the built-in tasks and the reference scores up to date, all in one
    // write transaction (another process may be doing the same: the lock orders them)
    WriteTxn txn(db_, path_);
    const int v = user_version(db_, path_);
    if (v > kVersion) throw newer(v);
    if (v == 0) {
      if (auto e = foreign()) throw *e;
    }
    for (int step = v; step < kVersion; ++step) sql::exec(db_, path_, kMigrations[step]);
    if (v != kVersion)
      sql::exec(db_, path_, sql::cat("PRAGMA user_version = ", std::to_string(kVersion)));
    // the paper's tasks, and their variants (a suite's members such as hand_over_free, CI's
    // reduced tasks) so that references and scores can name them; tasks() lists the former only
    for (auto* list : {&tasks::task_registry(), &tasks::variant_registry()})
      for (auto& e : *list) upsert_task(db_, path_, builtin_record(e.spec()));
    load_references(db_, path_);
    load_time_to_goal(db_, path_);
    txn.commit();
    sync_suites();
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

// The suites of configs/suites, as records (members: train entries, then test entries; a
// multi-task suite's test split is its train split and is not repeated).
namespace {
SuiteRecord suite_record(const taskpack::Suite& su) {
  SuiteRecord r;
  r.id = su.id;
  r.mode = taskpack::mode_name(su.mode);
  r.file = su.file;
  r.description = su.description;
  for (auto& e : su.train) r.members.push_back({e.label, e.task, "train", e.reward_scale});
  if (su.mode != taskpack::PackMode::kMultiTask)
    for (auto& e : su.test) r.members.push_back({e.label, e.task, "test", e.reward_scale});
  return r;
}
}  // namespace

void Registry::sync_suites() {
  const auto have = suites();
  for (const std::string& id : taskpack::known_suites()) {
    const SuiteRecord want = suite_record(taskpack::load_suite(id));
    bool same = false;
    for (auto& h : have) {
      if (h.id != want.id) continue;
      same = h.mode == want.mode && h.file == want.file && h.description == want.description &&
             h.members.size() == want.members.size();
      for (size_t i = 0; same && i < h.members.size(); ++i)
        same = h.members[i].label == want.members[i].label &&
               h.members[i].task == want.members[i].task &&
               h.members[i].split == want.members[i].split &&
               h.members[i].reward_scale == want.members[i].reward_scale;
    }
    if (!same) put_suite(want);  // written only when the suite file changed
  }
}

Registry::~Registry() { sqlite3_close(db_); }

std::vector<TaskRecord> Registry::tasks(bool by_age) const {
  std::string q = kTaskColumns;
  q.append("WHERE origin != 'variant' ");
  q.append(by_age ? "ORDER BY age_min, age_max, id" : "ORDER BY rowid");
  std::vector<TaskRecord> out;
  Stmt st(db_, path_, q.c_str());
  while (st.step()) out.push_back(read_task(st));
  Stmt src(db_, path_, "SELECT task, fact, source FROM task_sources");
  while (src.step())
    for (auto& t : out)
      if (t.id == src.text(0)) t.sources[src.text(1)] = src.text(2);
  return out;
}

std::optional<TaskRecord> Registry::task(const std::string& id) const {
  std::string q = kTaskColumns;
  q.append("WHERE id = ?1");
  Stmt st(db_, path_, q.c_str());
  st.bind(1, id);
  if (!st.step()) return std::nullopt;
  TaskRecord t = read_task(st);
  Stmt src(db_, path_, "SELECT fact, source FROM task_sources WHERE task = ?1");
  src.bind(1, id);
  while (src.step()) t.sources[src.text(0)] = src.text(1);
  return t;
}

void Registry::add_task(const TaskRecord& t) {
  check_task_record(t);
  WriteTxn txn(db_, path_);
  if (auto old = task(t.id)) {
    std::string msg = path_;
    msg.append(": task ")
        .append(in_quotes(t.id))
        .append(" is already registered (origin ")
        .append(old->origin)
        .append(")");
    throw Error(msg);
  }
  upsert_task(db_, path_, t);
  txn.commit();
}

std::vector<SuiteRecord> Registry::suites() const {
  std::vector<SuiteRecord> out;
  Stmt st(db_, path_, "SELECT id, mode, file, description FROM suites ORDER BY rowid");
  while (st.step()) {
    SuiteRecord s;
    s.id = st.text(0);
    s.mode = st.text(1);
    s.file = st.text(2);
    s.description = st.text(3);
    out.push_back(std::move(s));
  }
  Stmt m(db_, path_,
         "SELECT label, task, split, reward_scale FROM suite_members WHERE suite = ?1 "
         "ORDER BY position");
  for (auto& s : out) {
    m.bind(1, s.id);
    while (m.step()) s.members.push_back({m.text(0), m.text(1), m.text(2), m.dbl(3)});
    m.reset();
  }
  return out;
}

void Registry::put_suite(const SuiteRecord& s) {
  if (s.id.empty()) throw Error(path_ + ": a suite needs an id");
  for (auto& m : s.members) {
    if (m.split != "train" && m.split != "test")
      throw Error(path_ + ": suite " + in_quotes(s.id) + ", member " + in_quotes(m.label) +
                  ": split must be train or test, not " + in_quotes(m.split));
    if (!std::isfinite(m.reward_scale))
      throw Error(path_ + ": suite " + in_quotes(s.id) + ", member " + in_quotes(m.label) +
                  ": reward scale is not a finite number");
  }
  WriteTxn txn(db_, path_);
  Stmt del(db_, path_, "DELETE FROM suite_members WHERE suite = ?1");
  del.bind(1, s.id);
  del.run();
  Stmt up(db_, path_,
          "INSERT INTO suites (id, mode, file, description) VALUES (?1, ?2, ?3, ?4) "
          "ON CONFLICT (id) DO UPDATE SET mode = ?2, file = ?3, description = ?4");
  up.bind(1, s.id).bind(2, s.mode).bind(3, s.file).bind(4, s.description);
  up.run();
  Stmt ins(db_, path_,
           "INSERT INTO suite_members (suite, split, label, task, reward_scale, position) "
           "VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  int pos = 0;
  for (auto& m : s.members) {
    ins.bind(1, s.id).bind(2, m.split).bind(3, m.label).bind(4, m.task);
    ins.bind(5, m.reward_scale).bind(6, pos++);
    ins.run();
    ins.reset();
  }
  txn.commit();
}

int64_t Registry::begin_run(const RunRecord& r) {
  if (r.algo.empty()) throw Error(path_ + ": a run needs an algorithm");
  if (r.task.empty() == r.suite.empty())
    throw Error(path_ + ": a run is of one task or of one suite (task " + in_quotes(r.task) +
                ", suite " + in_quotes(r.suite) + ")");
  WriteTxn txn(db_, path_);
  Stmt st(db_, path_,
          "INSERT INTO runs (algo, task, suite, seed, steps, config_hash, code_version, run_dir, "
          "host, started, finished, status, dataset) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, "
          "?10, '', 'running', ?11)");
  st.bind(1, r.algo).bind(2, r.task).bind(3, r.suite).bind(4, static_cast<int64_t>(r.seed));
  st.bind(5, r.steps).bind(6, r.config_hash).bind(7, r.code_version).bind(8, r.run_dir);
  st.bind(9, r.host.empty() ? host_name() : r.host);
  st.bind(10, r.started.empty() ? utc_now() : r.started).bind(11, r.dataset);
  st.run();
  const int64_t id = sqlite3_last_insert_rowid(db_);
  txn.commit();
  return id;
}

void Registry::finish_run(int64_t id, const RunRecord& r, const std::vector<TaskScore>& scores) {
  const std::string status = r.status.empty() ? "finished" : r.status;
  if (!valid_status(status))
    throw Error(path_ + ": run " + std::to_string(id) + ": status " + in_quotes(status) +
                " is not one of running, finished, stopped, failed");
  for (size_t i = 0; i < scores.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if ((scores[i].label.empty() ? scores[i].task : scores[i].label) ==
          (scores[j].label.empty() ? scores[j].task : scores[j].label))
        throw Error(path_ + ": run " + std::to_string(id) + ": two scores with the label " +
                    in_quotes(scores[i].label.empty() ? scores[i].task : scores[i].label));
  WriteTxn txn(db_, path_);
  Stmt up(db_, path_,
          "UPDATE runs SET steps = ?2, status = ?3, finished = ?4, final_return = ?5, "
          "final_success = ?6 WHERE id = ?1");
  up.bind(1, id).bind(2, r.steps).bind(3, status);
  up.bind(4, r.finished.empty() && status != "running" ? utc_now() : r.finished);
  up.bind(5, r.final_return).bind(6, r.final_success);
  up.run();
  if (sqlite3_changes(db_) != 1)
    throw Error(path_ + ": no run with id " + std::to_string(id) + " to finish");
  Stmt del(db_, path_, "DELETE FROM run_scores WHERE run = ?1");
  del.bind(1, id);
  del.run();
  Stmt ins(db_, path_,
           "INSERT INTO run_scores (run, label, task, mean_return, success, episodes, position) "
           "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)");
  int pos = 0;
  for (auto& s : scores) {
    ins.bind(1, id).bind(2, s.label.empty() ? s.task : s.label).bind(3, s.task);
    ins.bind(4, s.mean_return).bind(5, s.success).bind(6, s.episodes).bind(7, pos++);
    ins.run();
    ins.reset();
  }
  txn.commit();
}

std::vector<RunRecord> Registry::runs() const {
  std::string q = kRunColumns;
  q.append("ORDER BY id");
  std::vector<RunRecord> out;
  Stmt st(db_, path_, q.c_str());
  while (st.step()) out.push_back(read_run(st));
  return out;
}

std::optional<RunRecord> Registry::run(int64_t id) const {
  std::string q = kRunColumns;
  q.append("WHERE id = ?1");
  Stmt st(db_, path_, q.c_str());
  st.bind(1, id);
  if (!st.step()) return std::nullopt;
  return read_run(st);
}

std::vector<TaskScore> Registry::scores(int64_t run_id) const {
  std::vector<TaskScore> out;
  Stmt st(db_, path_,
          "SELECT task, label, mean_return, success, episodes FROM run_scores WHERE run = ?1 "
          "ORDER BY position");
  st.bind(1, run_id);
  while (st.step()) out.push_back({st.text(0), st.text(1), st.dbl(2), st.opt(3), st.i64(4)});
  return out;
}

std::optional<RunRecord> Registry::run_by_dir(const std::string& run_dir) const {
  std::string q = kRunColumns;
  q.append("WHERE run_dir = ?1 ORDER BY id DESC LIMIT 1");
  Stmt st(db_, path_, q.c_str());
  st.bind(1, run_dir);
  if (!st.step()) return std::nullopt;
  return read_run(st);
}

int64_t Registry::add_evaluation(const Evaluation& e) {
  const auto fail = [&](const std::string& what) {
    throw Error(sql::cat(path_, ": evaluation of run ", std::to_string(e.run_id), ": ", what));
  };
  if (e.split != "train" && e.split != "test")
    fail(sql::cat("split ", in_quotes(e.split), " is not train or test"));
  if (e.adapt_episodes < 0 || e.adapt_steps < 0)
    fail(sql::cat("adaptation episodes ", std::to_string(e.adapt_episodes), " and steps ",
                  std::to_string(e.adapt_steps), " (expected >= 0)"));
  for (size_t i = 0; i < e.scores.size(); ++i) {
    const AdaptScore& s = e.scores[i];
    if (s.task.empty()) fail(sql::cat("score ", std::to_string(i + 1), " has no task"));
    if (!std::isfinite(s.return_before) || !std::isfinite(s.return_after))
      fail(sql::cat("the return of ", in_quotes(label_of(s)), " is not a finite number"));
    for (size_t j = 0; j < i; ++j)
      if (label_of(s) == label_of(e.scores[j]))
        fail(sql::cat("two scores with the label ", in_quotes(label_of(s))));
  }
  WriteTxn txn(db_, path_);
  {
    Stmt known(db_, path_, "SELECT 1 FROM runs WHERE id = ?1");
    known.bind(1, e.run_id);
    if (!known.step())
      throw Error(sql::cat(path_, ": no run with id ", std::to_string(e.run_id),
                           " to record an evaluation of (bidex registry scores)"));
  }
  Stmt st(db_, path_,
          "INSERT INTO evaluations (run, split, adapt_episodes, adapt_steps, seed, checkpoint, "
          "time) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)");
  st.bind(1, e.run_id).bind(2, e.split).bind(3, e.adapt_episodes).bind(4, e.adapt_steps);
  st.bind(5, static_cast<int64_t>(e.seed)).bind(6, e.checkpoint);
  st.bind(7, e.time.empty() ? utc_now() : e.time);
  st.run();
  const int64_t id = sqlite3_last_insert_rowid(db_);
  Stmt ins(db_, path_,
           "INSERT INTO evaluation_scores (evaluation, label, task, return_before, return_after, "
           "success_before, success_after, episodes, position) "
           "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)");
  int pos = 0;
  for (auto& s : e.scores) {
    ins.bind(1, id).bind(2, label_of(s)).bind(3, s.task).bind(4, s.return_before);
    ins.bind(5, s.return_after).bind(6, s.success_before).bind(7, s.success_after);
    ins.bind(8, s.episodes).bind(9, pos++);
    ins.run();
    ins.reset();
  }
  txn.commit();
  return id;
}

std::vector<Evaluation> Registry::evaluations(int64_t run_id) const {
  std::string q = kEvaluationColumns;
  q.append(run_id != 0 ? "WHERE run = ?1 ORDER BY id" : "ORDER BY id");
  std::vector<Evaluation> out;
  {
    Stmt st(db_, path_, q.c_str());
    if (run_id != 0) st.bind(1, run_id);
    while (st.step()) out.push_back(read_evaluation(st));
  }
  for (auto& e : out) read_evaluation_scores(db_, path_, e);
  return out;
}

std::optional<Evaluation> Registry::evaluation(int64_t id) const {
  std::string q = kEvaluationColumns;
  q.append("WHERE id = ?1");
  Evaluation e;
  {
    Stmt st(db_, path_, q.c_str());
    st.bind(1, id);
    if (!st.step()) return std::nullopt;
    e = read_evaluation(st);
  }
  read_evaluation_scores(db_, path_, e);
  return e;
}

void Registry::set_reference(const Reference& r) {
  if (!valid_kind(r.kind))
    throw Error(path_ + ": reference kind " + in_quotes(r.kind) + " is not random or ground_truth");
  if (!std::isfinite(r.value))
    throw Error(path_ + ": reference value of " + in_quotes(r.task) + " is not a finite number");
  if (r.source.empty())
    throw Error(path_ + ": the reference score of " + in_quotes(r.task) + " needs a source");
  WriteTxn txn(db_, path_);
  if (!task_exists(db_, path_, r.task))
    throw Error(path_ + ": no registered task " + in_quotes(r.task) + " (bidex registry list)");
  Stmt st(db_, path_,
          "INSERT INTO reference_scores (task, kind, value, source) VALUES (?1, ?2, ?3, ?4) "
          "ON CONFLICT (task, kind) DO UPDATE SET value = ?3, source = ?4");
  st.bind(1, r.task).bind(2, r.kind).bind(3, r.value).bind(4, r.source);
  st.run();
  txn.commit();
}

std::vector<Reference> Registry::references() const {
  std::vector<Reference> out;
  Stmt st(db_, path_,
          "SELECT task, kind, value, source FROM reference_scores ORDER BY task, kind");
  while (st.step()) out.push_back({st.text(0), st.text(1), st.dbl(2), st.text(3)});
  return out;
}

std::vector<TimeToGoal> Registry::time_to_goal() const {
  std::vector<TimeToGoal> out;
  Stmt st(db_, path_,
          "SELECT task, goal, target, reached_by, slot_steps, wall_s, trained, run, code_version, "
          "source FROM time_to_goal ORDER BY task");
  while (st.step())
    out.push_back({st.text(0), st.text(1), st.dbl(2), st.text(3), st.opt(4), st.opt(5),
                   st.dbl(6), st.text(7), st.text(8), st.text(9)});
  return out;
}

std::optional<Reference> Registry::reference(const std::string& task,
                                             const std::string& kind) const {
  Stmt st(db_, path_,
          "SELECT task, kind, value, source FROM reference_scores WHERE task = ?1 AND kind = ?2");
  st.bind(1, task).bind(2, kind);
  if (!st.step()) return std::nullopt;
  return Reference{st.text(0), st.text(1), st.dbl(2), st.text(3)};
}

void Registry::put_dataset(const DatasetRecord& d) {
  if (d.checksum.rfind("sha256:", 0) != 0 || d.task.empty())
    throw Error(path_ + ": a dataset needs its checksum (sha256:HEX) and task (got " +
                in_quotes(d.checksum) + ", " + in_quotes(d.task) + ")");
  WriteTxn txn(db_, path_);
  Stmt st(db_, path_,
          "INSERT OR REPLACE INTO datasets (checksum, dataset_id, task, quality, path, "
          "total_steps, total_episodes, ref_min, ref_max, policy, code_version, added) VALUES "
          "(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)");
  st.bind(1, d.checksum).bind(2, d.dataset_id).bind(3, d.task).bind(4, d.quality);
  st.bind(5, d.path).bind(6, d.total_steps).bind(7, d.total_episodes).bind(8, d.ref_min);
  st.bind(9, d.ref_max).bind(10, d.policy).bind(11, d.code_version);
  st.bind(12, d.added.empty() ? utc_now() : d.added);
  st.run();
  txn.commit();
}

std::vector<DatasetRecord> Registry::datasets() const {
  std::string q = kDatasetColumns;
  q.append("ORDER BY task, quality, added");
  std::vector<DatasetRecord> out;
  Stmt st(db_, path_, q.c_str());
  while (st.step()) out.push_back(read_dataset(st));
  return out;
}

std::optional<DatasetRecord> Registry::dataset(const std::string& checksum) const {
  std::string q = kDatasetColumns;
  q.append("WHERE checksum = ?1");
  Stmt st(db_, path_, q.c_str());
  st.bind(1, checksum);
  if (!st.step()) return std::nullopt;
  return read_dataset(st);
}

std::optional<double> Registry::offline_normalised(const std::string& checksum,
                                                   double mean_return) const {
  const auto d = dataset(checksum);
  if (!d) return std::nullopt;
  std::optional<double> lo = d->ref_min, hi = d->ref_max;
  if (!lo || !hi) {  // a replay dataset has none of its own: its task's, from the newest with both
    std::string q = kDatasetColumns;
    q.append("WHERE task = ?1 AND ref_min IS NOT NULL AND ref_max IS NOT NULL "
             "ORDER BY added DESC LIMIT 1");
    Stmt st(db_, path_, q.c_str());
    st.bind(1, d->task);
    if (!st.step()) return std::nullopt;
    const DatasetRecord other = read_dataset(st);
    lo = other.ref_min;
    hi = other.ref_max;
  }
  if (*hi == *lo) return std::nullopt;
  return 100.0 * (mean_return - *lo) / (*hi - *lo);
}

std::optional<double> Registry::normalised(const std::string& task, double mean_return) const {
  const auto random = reference(task, "random");
  const auto truth = reference(task, "ground_truth");
  if (!random || !truth || truth->value == random->value) return std::nullopt;
  return (mean_return - random->value) / (truth->value - random->value);
}

AdaptNormalised Registry::normalised_scores(const std::vector<AdaptScore>& scores) const {
  AdaptNormalised n;
  double before = 0, after = 0;
  for (const AdaptScore& s : scores) {
    n.before.push_back(normalised(s.task, s.return_before));
    n.after.push_back(normalised(s.task, s.return_after));
    if (n.before.back() && n.after.back()) {
      before += *n.before.back();
      after += *n.after.back();
      ++n.count;
    }
  }
  if (n.count > 0) {
    n.mean_before = before / n.count;
    n.mean_after = after / n.count;
  }
  return n;
}

}  // namespace bidex::registry
