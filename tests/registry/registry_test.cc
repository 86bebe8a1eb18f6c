// registry/: creating a registry (schema version, WAL mode, the built-in tasks in age order with
// their sources, the reference scores), migrating version-1 and version-2 files, refusing newer
// and non-SQLite files, runs and scores, meta-RL evaluations, normalised scores, the age report,
// two processes writing at once.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>

#include "core/error.h"
#include "core/files.h"
#include "registry/registry.h"
#include "registry/report.h"
#include "taskpack/suite.h"
#include "tasks/registry.h"
#include "tests/registry/registry_fixture.h"

using namespace bidex;
using namespace bidex::test;
using registry::AdaptNormalised;
using registry::AdaptScore;
using registry::Registry;

namespace {

// The ground truth of configs/registry/references.yaml, written out here by hand: the original
// code's final PPO returns of the catch family and the doors (the original's rewards), and
// bidex's own PPO where the original's are missing or on another reward scale (hand_over pays
// bidex's goal bonus), each with its own source.
const std::string kOriginal =
    "original code's published PPO learning curves, final value near 1e8 steps, mean of 10 seeds";
const std::vector<std::pair<std::string, double>> kGroundTruth = {
    {"hand_over", 274.275},       {"catch_underarm", 17.8},      {"catch_over2underarm", 28.4},
    {"catch_abreast", 43.4},      {"two_catch_underarm", 14.1},  {"door_open_inward", 467},
    {"door_open_outward", 580},   {"door_close_inward", 295},    {"door_close_outward", 1038},
    {"lift_underarm", 1432.16},   {"scissors", 611.625},         {"bottle_cap", 493.569},
    {"push_block", 602.088},      {"switch", 452.254},           {"pen", 421.488},
    {"swing_cup", 6881.44},       {"grasp_and_place", 434.516},  {"block_stack", 872.151},
    {"re_orientation", 3727.330},  {"pour_water", 734.525}};

// A task as `add_task` takes it: human age `age_min`-`age_max` months, 10 observations, 4
// actions, easy, from a YAML file elsewhere.
registry::TaskRecord added_task(const std::string& id, int age_min, int age_max) {
  registry::TaskRecord t;
  t.id = id;
  t.paper_name = "Added Task";
  t.age_min = age_min;
  t.age_max = age_max;
  t.age_text = age_min == age_max ? std::to_string(age_min)
                                  : std::to_string(age_min) + "-" + std::to_string(age_max);
  t.difficulty = "easy";
  t.skill = "a skill";
  t.obs_dim = 10;
  t.act_dim = 4;
  t.origin = "/somewhere/added.yaml";
  return t;
}

std::vector<std::string> ids(const std::vector<registry::TaskRecord>& ts) {
  std::vector<std::string> out;
  for (auto& t : ts) out.push_back(t.id);
  return out;
}

// The message of the bidex::Error that `f` throws.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  FAIL("expected a bidex::Error, none was thrown");
  return "";
}

}  // namespace

TEST_CASE("a new registry: schema version, WAL mode, the built-in tasks by age with their "
          "sources, the reference scores", "[registry]") {
  RegTempDir dir;
  const std::string path = dir.file("nested/folder/registry.sqlite");  // folders are created
  {
    Registry reg(path);
    CHECK(reg.path() == path);

    // the paper's twenty, in the paper's order and in age order (written out by hand)
    const auto& builtin = tasks::task_registry();
    REQUIRE(builtin.size() == 20);
    const auto by_reg = reg.tasks(false);
    REQUIRE(by_reg.size() == 20);
    for (size_t i = 0; i < builtin.size(); ++i) CHECK(by_reg[i].id == builtin[i].spec().id);
    CHECK(ids(reg.tasks(true)) == paper_tasks_by_age());

    for (auto& e : builtin) {
      const auto& sp = e.spec();
      INFO(sp.id);
      const auto t = reg.task(sp.id);
      REQUIRE(t);
      CHECK(t->version == sp.version);
      CHECK(t->paper_name == sp.paper_name);
      CHECK(t->original_name == sp.original_name);
      CHECK(t->age_min == sp.age.min_months);
      CHECK(t->age_max == sp.age.max_months);
      CHECK(t->age_text == sp.age.text);
      CHECK(t->difficulty == tasks::difficulty_name(sp.difficulty));
      CHECK(t->skill == sp.skill);
      CHECK(t->obs_dim == sp.obs.dim());
      CHECK(t->act_dim == sp.act.dim());
      CHECK(t->origin == "builtin");
      CHECK(t->sources.size() == 7);
      const std::string table = sp.age.from_commented_row
                                    ? "paper source, a commented-out row of the task table"
                                    : "paper, task table";
      CHECK(t->sources.at("age") == table);
      CHECK(t->sources.at("difficulty") == table);
      CHECK(t->sources.at("skill") == table);
      CHECK(t->sources.at("act_dim") == "paper, observation and action tables");
      CHECK(t->sources.at("obs_dim") == (sp.id == "grasp_and_place"
                                             ? "original code; the paper gives no table"
                                             : "paper, observation and action tables"));
      CHECK(t->sources.at("names") == "bidex task spec");
      CHECK(t->sources.at("version") == "bidex task spec");
    }
    // spot checks against the paper's table, by hand
    CHECK(reg.task("hand_over")->age_text == "9-10");
    CHECK(reg.task("hand_over")->sources.at("age") ==
          "paper source, a commented-out row of the task table");
    CHECK(reg.task("catch_underarm")->sources.at("age") == "paper, task table");
    CHECK(reg.task("two_catch_underarm")->age_min == 216);
    CHECK(reg.task("grasp_and_place")->obs_dim == 425);
    // variants are registered, with their task, but not listed among the paper's tasks
    for (const char* id : {"catch_underarm_raise", "hand_over_free"}) {
      INFO(id);
      const auto v = reg.task(id);
      REQUIRE(v);
      CHECK(v->origin == "variant");
      CHECK(v->sources.at("variant_of") == (std::string(id) == "hand_over_free" ? "hand_over"
                                                                               : "catch_underarm"));
      for (auto& t : reg.tasks(true)) CHECK(t.id != id);
    }

    // the twenty ground truths and the twenty measured random scores, and hand_over_free's two
    // (MT4's and ML4's variant, so that their normalised means cover all four members)
    const auto refs = reg.references();
    CHECK(refs.size() == kGroundTruth.size() + 20 + 2);
    CHECK(reg.reference("hand_over_free", "ground_truth")->value == Approx(268.149));
    CHECK(reg.reference("hand_over_free", "ground_truth")->source.find(
              "suites-h200x4/hand_over_free/eval.json") != std::string::npos);
    CHECK(reg.reference("hand_over_free", "random")->value == Approx(3.25619));
    for (auto& [task, value] : kGroundTruth) {
      INFO(task);
      const auto r = reg.reference(task, "ground_truth");
      REQUIRE(r);
      CHECK(r->value == Approx(value));
      if (task.rfind("catch", 0) == 0 || task.rfind("door", 0) == 0 || task == "two_catch_underarm")
        CHECK(r->source == kOriginal);
      else
        CHECK(r->source.rfind("bidex PPO on the GPU path, ", 0) == 0);
    }
    CHECK(reg.reference("lift_underarm", "ground_truth")->source.find(
              "sweep-h100x4/lease7/lift_underarm-m100/eval.json") != std::string::npos);
    CHECK(reg.reference("scissors", "ground_truth")->source.find(
              "sweep-h100x4/lease7/scissors-m100/eval.json") != std::string::npos);
    CHECK(reg.reference("switch", "ground_truth")->source.find(
              "sweep-h100x4/switch/eval.json") != std::string::npos);
    // every one of the twenty paper tasks has a ground truth
    CHECK(kGroundTruth.size() == 20);
    for (auto& t : reg.tasks(false)) CHECK(reg.reference(t.id, "ground_truth"));
    // every paper task has a random score with its source (spot values from references.yaml)
    for (auto& t : reg.tasks(false)) {
      INFO(t.id);
      const auto r = reg.reference(t.id, "random");
      REQUIRE(r);
      CHECK(r->source.find("bidex eval --random") != std::string::npos);
    }
    CHECK(reg.reference("hand_over", "random")->value == Approx(3.2683));
    CHECK(reg.reference("switch", "random")->value == Approx(86.605));  // version 2
    CHECK(reg.reference("switch", "random")->source.find(
              "random-references-issue36-2core.json") != std::string::npos);
    CHECK(reg.reference("pen", "random")->value == Approx(23.9298));  // version 2
    CHECK(reg.reference("pen", "random")->source.find("random-references-pen-v2-2core.json") !=
          std::string::npos);

    // the suites of configs/suites (the paper's six and the goal distributions), with their
    // members and reward scales
    const auto suites = reg.suites();
    REQUIRE(suites.size() == taskpack::known_suites().size());
    for (auto& su : suites) {
      INFO(su.id);
      if (su.id == "MT20") {
        CHECK(su.mode == "multitask");
        REQUIRE(su.members.size() == 20);
        int scaled = 0;
        for (auto& m : su.members) scaled += m.reward_scale == 0.1;
        CHECK(scaled == 11);
      }
      if (su.id == "ML4") {
        CHECK(su.mode == "meta");
        REQUIRE(su.members.size() == 4);
        CHECK(su.members.back().split == "test");
        CHECK(su.members.back().task == "two_catch_underarm");
        CHECK(su.members[1].task == "hand_over_free");
      }
    }
  }
  // read back without bidex
  RawDb raw(path);
  CHECK(registry::schema_version() == 5);
  CHECK(raw.value("PRAGMA user_version") == "5");
  CHECK(raw.value("PRAGMA journal_mode") == "wal");
  // the twenty tasks and two variants (catch_underarm_raise, hand_over_free: a variant_of source)
  CHECK(raw.value("SELECT count(*) FROM tasks") == "22");
  CHECK(raw.value("SELECT count(*) FROM task_sources") == "156");
  // the shipped ground truths and 20 random scores, and hand_over_free's two
  CHECK(raw.value("SELECT count(*) FROM reference_scores") ==
        std::to_string(kGroundTruth.size() + 20 + 2));
  CHECK(raw.value("SELECT count(*) FROM suites") ==
        std::to_string(taskpack::known_suites().size()));
  CHECK(raw.value("SELECT count(*) FROM suite_members WHERE suite = 'ML20'") == "20");
}

TEST_CASE("opening again changes nothing and keeps a reference set by hand", "[registry]") {
  RegTempDir dir;
  const std::string path = dir.file("r.sqlite");
  {
    Registry reg(path);
    reg.set_reference({"hand_over", "ground_truth", 25.0, "my own run"});
    reg.set_reference({"hand_over", "random", 0.5, "bidex play --policy random"});
  }
  Registry reg(path);
  CHECK(reg.tasks(false).size() == 20);
  CHECK(reg.references().size() == kGroundTruth.size() + 20 + 2);  // + hand_over_free's
  CHECK(reg.reference("hand_over", "ground_truth")->value == 25.0);
  CHECK(reg.reference("hand_over", "ground_truth")->source == "my own run");
  CHECK(reg.reference("hand_over", "random")->value == 0.5);
  CHECK_THROWS_AS(reg.set_reference({"no_such_task", "random", 1, "x"}), Error);
  CHECK_THROWS_AS(reg.set_reference({"pen", "expert", 1, "x"}), Error);
  CHECK_THROWS_AS(reg.set_reference({"pen", "random", NAN, "x"}), Error);
  CHECK_THROWS_AS(reg.set_reference({"pen", "random", 1, ""}), Error);
}

TEST_CASE("the sweep's time to each task's goal: the shipped file gives all twenty, its goals "
          "agree with the ground truths", "[registry]") {
  RegTempDir dir;
  Registry reg(dir.file("r.sqlite"));
  const auto rows = reg.time_to_goal();
  std::vector<std::string> tasks;
  for (auto& r : rows) tasks.push_back(r.task);
  std::vector<std::string> builtin;
  for (auto& t : reg.tasks(false)) builtin.push_back(t.id);
  std::sort(builtin.begin(), builtin.end());
  CHECK(tasks == builtin);  // by task, one row each
  int original = 0;
  for (auto& r : rows) {
    INFO(r.task);
    if (r.goal == "original_final") {
      // the goal is the ground truth where that is the original's published final
      ++original;
      CHECK(r.target == Approx(reg.reference(r.task, "ground_truth")->value));
      CHECK(reg.reference(r.task, "ground_truth")->source == kOriginal);
    } else {
      CHECK(r.goal == "success");
      CHECK(r.target == 0.8);
      CHECK(reg.reference(r.task, "ground_truth")->source != kOriginal);
    }
    if (r.reached_by == "not_reached") {
      CHECK_FALSE(r.slot_steps);
    } else {
      REQUIRE(r.slot_steps);
      CHECK(*r.slot_steps > 0);
      CHECK(*r.slot_steps <= r.trained);
      CHECK(*r.wall_s > 0);
    }
    // a committed run folder of the sweep (bench/results/sweep-<machine>/...)
    CHECK_THAT(r.run, Catch::StartsWith("bench/results/sweep-"));
    CHECK(std::filesystem::exists(std::string(BIDEX_SOURCE_DIR) + "/" + r.run + "/config.yaml"));
    CHECK_FALSE(r.source.empty());
  }
  CHECK(original == 8);  // the nine published curves but hand_over's, whose ground truth is bidex's
  // every task has met its goal: re_orientation, the last, in training at 164.4M slot-steps
  // (the twenty-third lease)
  const auto& reo = rows[static_cast<size_t>(
      std::find(tasks.begin(), tasks.end(), "re_orientation") - tasks.begin())];
  CHECK(reo.reached_by == "training");
  CHECK(*reo.slot_steps == 164364288);
}

TEST_CASE("a bad time-to-goal file is an error naming the file, the key and the value, and the "
          "registry keeps what it had", "[registry]") {
  RegTempDir dir;
  const std::string path = dir.file("r.sqlite"), file = dir.file("ttg.yaml");
  const std::string row =
      "    pen: {goal: success, target: 0.8, trained: 5.0e7, run: r, commit: c, by: training, "
      "slot_steps: 1.0e7, wall_s: 300}\n";
  write_file_atomic(file, "source: \"test\"\nsuccess_goal: 0.8\nvalues:\n" + row);
  ::setenv("BIDEX_TIME_TO_GOAL", file.c_str(), 1);
  {
    Registry reg(path);
    REQUIRE(reg.time_to_goal().size() == 1);  // the file owns the table: one row
    CHECK(reg.time_to_goal()[0].slot_steps == 1.0e7);
    CHECK(reg.time_to_goal()[0].source == "test");
  }
  const std::vector<std::tuple<std::string, std::string, std::string>> bad = {
      {"    penn: {goal: success}\n", "values.penn", "unknown task 'penn'"},
      {"    pen: {goal: fast, target: 0.8, trained: 1, run: r, commit: c, by: training, "
       "slot_steps: 1, wall_s: 1}\n", "values.pen.goal", "fast"},
      {"    pen: {goal: success, target: 0.8, trained: 1, run: r, commit: c, by: training, "
       "slot_steps: null, wall_s: 1}\n", "values.pen.slot_steps", "null"},
      {"    pen: {goal: success, target: 0.8, trained: 1, run: r, commit: c, by: soon, "
       "slot_steps: 1, wall_s: 1}\n", "values.pen.by", "soon"},
  };
  for (auto& [text, key, actual] : bad) {
    INFO(text);
    write_file_atomic(file, "source: \"test\"\nsuccess_goal: 0.8\nvalues:\n" + text);
    const std::string msg = error_of([&] { Registry reg(path); });
    CHECK_THAT(msg, Catch::Contains(file));
    CHECK_THAT(msg, Catch::Contains(key));
    CHECK_THAT(msg, Catch::Contains(actual));
  }
  ::unsetenv("BIDEX_TIME_TO_GOAL");
  Registry reg(path);  // the failed opens wrote nothing; the shipped file replaces the test's
  CHECK(reg.time_to_goal().size() == 20);
}

namespace {
// Writes `text` as the references file that BIDEX_REFERENCES names.
void write_references(const std::string& path, const std::string& text) {
  write_file_atomic(path, text);
  ::setenv("BIDEX_REFERENCES", path.c_str(), 1);
}
}  // namespace

TEST_CASE("a new edition of the references file updates and withdraws the rows it made, and "
          "no other", "[registry]") {
  RegTempDir dir;
  const std::string path = dir.file("r.sqlite"), refs = dir.file("refs.yaml");
  write_references(refs,
                   "ground_truth:\n  source: \"paper v1\"\n  values:\n    hand_over: 30\n"
                   "    pen: {value: 9, source: \"my pen run\"}\n    scissors: 300\n"
                   "random:\n  source: \"random v1\"\n  values:\n    hand_over: 3\n"
                   "    pen: 0.1\n    switch: 8000\n");
  {
    Registry reg(path);
    CHECK(reg.references().size() == 6);
    // a user's own references, set by hand: never touched by the file
    reg.set_reference({"switch", "random", 8100, "bidex eval --random: 64 episodes"});
    reg.set_reference({"catch_underarm", "ground_truth", 20, "my catch run"});
  }
  // the next edition: hand_over's random and ground truth change, the random section's source
  // changes (naming the old one in `replaces`), pen's ground truth (its source replaced) and
  // scissors' are withdrawn, switch keeps the user's value, a new task appears
  write_references(refs,
                   "ground_truth:\n  source: \"paper v1\"\n  replaces: [\"my pen run\"]\n"
                   "  values:\n    hand_over: 31\n"
                   "random:\n  source: \"random v2\"\n  replaces: [\"random v1\"]\n"
                   "  values:\n    hand_over: 3.5\n    pen: 0.2\n    switch: 8500\n"
                   "    lift_underarm: 600\n");
  {
    Registry reg(path);
    CHECK(reg.reference("hand_over", "ground_truth")->value == 31);
    CHECK(reg.reference("hand_over", "random")->value == 3.5);
    CHECK(reg.reference("hand_over", "random")->source == "random v2");
    CHECK(reg.reference("pen", "random")->value == Approx(0.2));
    CHECK(reg.reference("lift_underarm", "random")->value == 600);
    CHECK_FALSE(reg.reference("pen", "ground_truth"));       // its own source is replaced
    CHECK_FALSE(reg.reference("scissors", "ground_truth"));  // withdrawn
    CHECK(reg.reference("switch", "random")->value == 8100);  // the user's
    CHECK(reg.reference("switch", "random")->source == "bidex eval --random: 64 episodes");
    CHECK(reg.reference("catch_underarm", "ground_truth")->value == 20);
    CHECK(reg.references().size() == 6);
    // the normalised score follows the new edition: (17.25 - 3.5) / (31 - 3.5) = 0.5
    CHECK(*reg.normalised("hand_over", 17.25) == Approx(0.5));
  }
  // a row of an older edition that the newest does not name in `replaces` is no longer the
  // file's: kept as it is
  write_references(refs, "random:\n  source: \"random v3\"\n  values:\n    hand_over: 4\n");
  {
    Registry reg(path);
    CHECK(reg.reference("hand_over", "random")->value == 3.5);
    CHECK(reg.reference("hand_over", "ground_truth")->value == 31);  // a missing section
                                                                     // claims nothing
    CHECK(reg.reference("pen", "random")->value == Approx(0.2));
  }
  ::unsetenv("BIDEX_REFERENCES");
}

TEST_CASE("the shipped references file updates a ground truth that an earlier edition of it "
          "wrote", "[registry]") {
  RegTempDir dir;
  const std::string path = dir.file("r.sqlite");
  // pour_water's ground truth as the two editions before its 82.6M run wrote it: the 33.7M run,
  // then the 53.4M run
  const std::vector<std::pair<double, std::string>> editions = {
      {635.309,
       "bidex PPO on the GPU path, 33.7M slot-steps at 4,096 slots, commit 666ae61, with "
       "bench/sweep/pour_lift_steep.yaml (pour_water version 2's default reward): its mean "
       "action's return over 256 episodes "
       "(bench/results/sweep-h100x4/lease7/pour_water-cpour_lift_steep-oslots4096-e-m100/"
       "eval.json)"},
      {705.424,
       "bidex PPO on the GPU path, version 2 at 4,096 slots, 53.4M slot-steps in two slices "
       "(commits 14f78f5 and d25070f, 4 x H200 and 2 x H200): its mean action's return over 256 "
       "episodes (bench/results/suites-h200x2/pour_water/eval.json); 635.309 at 33.7M before "
       "(bench/results/sweep-h100x4/lease7/pour_water-cpour_lift_steep-oslots4096-e-m100/)"}};
  for (const auto& [value, source] : editions) {
    INFO("the earlier edition's value " << value);
    {
      Registry reg(path);
      reg.set_reference({"pour_water", "ground_truth", value, source});
      CHECK(reg.reference("pour_water", "ground_truth")->value == Approx(value));
    }
    Registry reg(path);  // the shipped file names the old source in `replaces`: its row again
    CHECK(reg.reference("pour_water", "ground_truth")->value == Approx(734.525));
    CHECK_THAT(reg.reference("pour_water", "ground_truth")->source,
               Catch::Contains("82.6M slot-steps"));
  }
}

TEST_CASE("normalised score = (return - random) / (ground truth - random), empty without a "
          "reference, and an evaluation's scores and their means", "[registry]") {
  RegTempDir dir;
  Registry reg(dir.file("r.sqlite"));
  // hand_over: ground truth 274.275 (references.yaml), random 2 set here
  reg.set_reference({"hand_over", "random", 2.0, "test"});
  // by hand: (138.1375 - 2) / (274.275 - 2) = 136.1375 / 272.275 = 0.5
  REQUIRE(reg.normalised("hand_over", 138.1375));
  CHECK(*reg.normalised("hand_over", 138.1375) == Approx(0.5));
  CHECK(*reg.normalised("hand_over", 2.0) == Approx(0.0).margin(1e-12));
  CHECK(*reg.normalised("hand_over", 274.275) == Approx(1.0));
  CHECK(*reg.normalised("hand_over", -134.1375) == Approx(-0.5));  // below random: negative
  CHECK(*reg.normalised("hand_over", 410.4125) == Approx(1.5));    // above ground truth: > 1
  // a random score above the return and a ground truth below it: the sign still follows
  reg.set_reference({"pen", "random", 10.0, "test"});
  reg.set_reference({"pen", "ground_truth", -10.0, "test"});
  CHECK(*reg.normalised("pen", 0.0) == Approx(0.5));
  // missing references: the file gives every paper task both (and hand_over_free, a variant);
  // a task added by hand gets a random score only here
  reg.add_task(added_task("added_task", 14, 14));
  reg.set_reference({"added_task", "random", 1.0, "test"});
  CHECK_FALSE(reg.normalised("added_task", 10.0));  // random only
  CHECK_FALSE(reg.normalised("no_such_task", 10.0));
  // equal references cannot normalise
  reg.set_reference({"scissors", "random", 3.0, "test"});
  reg.set_reference({"scissors", "ground_truth", 3.0, "test"});
  CHECK_FALSE(reg.normalised("scissors", 10.0));

  // a meta-RL evaluation's entries: each before and after, and the means over the entries
  // whose task has both references (hand_over and pen here; catch_underarm_raise, a variant,
  // has none)
  std::vector<AdaptScore> scores(3);
  scores[0].task = "hand_over";
  scores[0].return_before = 2.0;   // 0
  scores[0].return_after = 138.1375;  // 0.5
  scores[1].task = "catch_underarm_raise";
  scores[1].return_before = 1.0;
  scores[1].return_after = 2.0;
  scores[2].task = "pen";
  scores[2].return_before = 10.0;  // 0
  scores[2].return_after = -10.0;  // 1
  const AdaptNormalised n = reg.normalised_scores(scores);
  REQUIRE(n.before.size() == 3);
  REQUIRE(n.after.size() == 3);
  CHECK(*n.after[0] == Approx(0.5));
  CHECK_FALSE(n.before[1]);
  CHECK_FALSE(n.after[1]);
  CHECK(*n.after[2] == Approx(1.0));
  CHECK(n.count == 2);
  CHECK(*n.mean_before == Approx(0.0).margin(1e-12));
  CHECK(*n.mean_after == Approx(0.75));
  const AdaptNormalised none = reg.normalised_scores({scores[1]});
  CHECK(none.count == 0);
  CHECK_FALSE(none.mean_before);
  CHECK_FALSE(none.mean_after);
}

TEST_CASE("runs, their scores and suites round-trip", "[registry]") {
  RegTempDir dir;
  Registry reg(dir.file("r.sqlite"));
  registry::RunRecord r;
  r.algo = "ppo";
  r.task = "hand_over";
  r.seed = std::numeric_limits<uint64_t>::max();  // stored as the signed 64-bit pattern
  r.config_hash = "abc123";
  r.code_version = "0.1.0";
  r.run_dir = "runs/hand_over-ppo";
  r.host = "testhost";
  const int64_t id = reg.begin_run(r);
  CHECK(id >= 1);
  {
    const auto got = reg.run(id);
    REQUIRE(got);
    CHECK(got->status == "running");
    CHECK(got->seed == std::numeric_limits<uint64_t>::max());
    CHECK(got->started.size() == 20);  // 2026-11-22T15:00:00Z
    CHECK(got->finished.empty());
    CHECK(got->host == "testhost");
    CHECK_FALSE(got->final_return);
  }
  r.steps = 123456;
  r.status = "stopped";
  r.final_return = 12.5;
  r.final_success = 0.25;
  reg.finish_run(id, r, {{"hand_over", "", 12.5, 0.25, 40}});
  {
    const auto got = reg.run(id);
    CHECK(got->status == "stopped");
    CHECK(got->steps == 123456);
    CHECK(got->final_return == 12.5);
    CHECK(got->final_success == 0.25);
    CHECK(got->finished.size() == 20);
    const auto s = reg.scores(id);
    REQUIRE(s.size() == 1);
    CHECK(s[0].label == "hand_over");  // an empty label is the task id
    CHECK(s[0].episodes == 40);
  }
  // finishing again replaces the scores
  r.status = "finished";
  reg.finish_run(id, r, {{"hand_over", "", 14.0, std::nullopt, 10}});
  CHECK(reg.scores(id).size() == 1);
  CHECK(reg.scores(id)[0].mean_return == 14.0);
  CHECK_FALSE(reg.scores(id)[0].success);

  // a suite run with a score per member, kept in order
  registry::RunRecord s;
  s.algo = "ppo";
  s.suite = "MT4";
  const int64_t sid = reg.begin_run(s);
  CHECK(sid > id);
  reg.finish_run(sid, s,
                 {{"two_catch_underarm", "two_catch_underarm", 5, 0.1, 3},
                  {"catch_underarm", "catch_underarm", 6, 0.2, 4},
                  {"hand_over", "hand_over_free", 7, std::nullopt, 5}});
  const auto ss = reg.scores(sid);
  REQUIRE(ss.size() == 3);
  CHECK(ss[0].task == "two_catch_underarm");
  CHECK(ss[2].label == "hand_over_free");
  CHECK(reg.runs().size() == 2);
  CHECK(reg.runs()[1].suite == "MT4");
  CHECK(reg.runs()[1].task.empty());

  // errors
  CHECK_THROWS_AS(reg.finish_run(9999, r, {}), Error);
  registry::RunRecord bad = r;
  bad.status = "exploded";
  CHECK_THROWS_AS(reg.finish_run(id, bad, {}), Error);
  CHECK_THROWS_AS(reg.finish_run(id, r, {{"pen", "x", 1, 0, 1}, {"pen", "x", 2, 0, 1}}), Error);
  bad = r;
  bad.suite = "MT4";  // a task and a suite
  CHECK_THROWS_AS(reg.begin_run(bad), Error);
  bad = registry::RunRecord{};
  bad.algo = "ppo";  // neither
  CHECK_THROWS_AS(reg.begin_run(bad), Error);

  // suites: put, then replace (a suite of its own beside the six of configs/suites)
  const size_t shipped = reg.suites().size();
  registry::SuiteRecord suite{"MY4", "multitask", "my/MY4.yaml", "four catch tasks", {}};
  suite.members = {{"catch_underarm", "catch_underarm", "train", 1.0},
                   {"hand_over", "hand_over", "train", 0.1},
                   {"catch_underarm", "catch_underarm", "test", 1.0}};
  reg.put_suite(suite);
  auto mine = [&] {
    for (auto& s : reg.suites())
      if (s.id == "MY4") return s;
    FAIL("suite MY4 missing");
    return registry::SuiteRecord{};
  };
  CHECK(reg.suites().size() == shipped + 1);
  CHECK(mine().members.size() == 3);
  CHECK(mine().members[1].reward_scale == 0.1);
  suite.members.pop_back();
  suite.description = "changed";
  reg.put_suite(suite);
  CHECK(reg.suites().size() == shipped + 1);
  CHECK(mine().description == "changed");
  CHECK(mine().members.size() == 2);
  suite.members[0].split = "validation";
  CHECK_THROWS_AS(reg.put_suite(suite), Error);
  CHECK(mine().members.size() == 2);  // nothing written
}

TEST_CASE("adding a task: registered in age order, and a duplicate or impossible one is refused",
          "[registry]") {
  RegTempDir dir;
  Registry reg(dir.file("r.sqlite"));
  registry::TaskRecord t = added_task("toddler_task", 14, 16);
  t.paper_name = "Toddler Task";
  t.difficulty = "medium";
  t.origin = "/somewhere/toddler.yaml";
  t.sources["age"] = "a book";
  reg.add_task(t);
  const auto by_age = ids(reg.tasks(true));
  REQUIRE(by_age.size() == 21);
  CHECK(by_age[13] == "toddler_task");  // after the four doors at 13, before re_orientation 18
  CHECK(by_age[14] == "re_orientation");
  CHECK(reg.task("toddler_task")->sources.at("age") == "a book");
  CHECK(reg.task("toddler_task")->origin == "/somewhere/toddler.yaml");
  CHECK_THAT(error_of([&] { reg.add_task(t); }), Catch::Contains("already registered"));
  registry::TaskRecord dup = t;
  dup.id = "hand_over";
  CHECK_THAT(error_of([&] { reg.add_task(dup); }), Catch::Contains("'hand_over'"));
  CHECK(reg.task("hand_over")->origin == "builtin");
  registry::TaskRecord bad = t;
  bad.id = "bad";
  bad.age_max = 10;
  CHECK_THROWS_AS(reg.add_task(bad), Error);
  bad = t;
  bad.id = "bad";
  bad.difficulty = "impossible";
  CHECK_THROWS_AS(reg.add_task(bad), Error);
  bad = t;
  bad.id = "bad";
  bad.obs_dim = -3;
  CHECK_THROWS_AS(reg.add_task(bad), Error);
  CHECK(reg.tasks(false).size() == 21);
}

TEST_CASE("a version-1 file with data is migrated to the current version, its data kept",
          "[registry]") {
  RegTempDir dir;
  const std::string path = dir.file("old.sqlite");
  {
    RawDb raw(path);
    raw.exec(registry::migration_sql(1));
    raw.exec("PRAGMA user_version = 1");
    // a version-1 registry as the version-1 code left it: a built-in task with dimensions since
    // changed, a task added by hand, runs, and a reference score without a source
    raw.exec(
        "INSERT INTO tasks VALUES ('hand_over', 1, 'Hand Over', 'ShadowHandOver', 9, 10, '9-10', "
        "'easy', 'old skill text', 999, 40, 'builtin');"
        "INSERT INTO tasks VALUES ('old_task', 3, 'Old Task', '', 20, 22, '20-22', 'hard', "
        "'an old skill', 100, 20, '/old/old_task.yaml');"
        "INSERT INTO runs (algo, task, seed, steps, started, finished, status, final_return, "
        "final_success) VALUES ('ppo', 'hand_over', 7, 1000, '2026-01-01T00:00:00Z', "
        "'2026-01-01T01:00:00Z', 'finished', 20.5, 0.5);"
        "INSERT INTO runs (algo, task, seed, started, status) VALUES ('ppo', 'old_task', 8, "
        "'2026-01-02T00:00:00Z', 'running');"
        "INSERT INTO reference_scores VALUES ('hand_over', 'random', 1.5);"
        "INSERT INTO reference_scores VALUES ('old_task', 'ground_truth', 50);");
    CHECK(raw.value("SELECT count(*) FROM sqlite_master WHERE name = 'run_scores'") == "0");
  }
  {
    Registry reg(path);
    // tasks: the built-in one brought up to date, the hand-added one kept
    CHECK(reg.tasks(false).size() == 21);
    CHECK(reg.task("hand_over")->obs_dim == 398);
    CHECK(reg.task("hand_over")->sources.at("age") ==
          "paper source, a commented-out row of the task table");
    const auto old = reg.task("old_task");
    REQUIRE(old);
    CHECK(old->version == 3);
    CHECK(old->age_text == "20-22");
    CHECK(old->origin == "/old/old_task.yaml");
    CHECK(old->sources.empty());
    // runs kept, with the new column's default
    const auto runs = reg.runs();
    REQUIRE(runs.size() == 2);
    CHECK(runs[0].id == 1);
    CHECK(runs[0].task == "hand_over");
    CHECK(runs[0].suite.empty());
    CHECK(runs[0].seed == 7);
    CHECK(runs[0].steps == 1000);
    CHECK(runs[0].final_return == 20.5);
    CHECK(runs[0].finished == "2026-01-01T01:00:00Z");
    CHECK(runs[1].status == "running");
    // reference scores kept, their unknown source said so; the ground truths added beside them
    const auto random = reg.reference("hand_over", "random");
    REQUIRE(random);
    CHECK(random->value == 1.5);
    CHECK_THAT(random->source, Catch::Contains("schema version 1"));
    CHECK(reg.reference("old_task", "ground_truth")->value == 50);
    CHECK(reg.reference("hand_over", "ground_truth")->value == Approx(274.275));
    // the shipped ground truths and 19 random, and hand_over_free's two
    CHECK(reg.references().size() == 2 + kGroundTruth.size() + 19 + 2);
    // the new tables work, also for the old runs
    registry::RunRecord done = runs[1];
    done.status = "finished";
    reg.finish_run(2, done, {{"old_task", "", 30, 0.5, 5}});
    CHECK(reg.scores(2).size() == 1);
    CHECK(reg.run(2)->status == "finished");
    reg.put_suite({"S", "multitask", "", "", {{"a", "hand_over", "train", 1.0}}});
    CHECK(reg.suites().size() == 1 + taskpack::known_suites().size());  // beside configs/suites'
    registry::RunRecord s;
    s.algo = "ppo";
    s.suite = "S";
    CHECK(reg.begin_run(s) == 3);
    CHECK(*reg.normalised("hand_over", 16.15) == Approx((16.15 - 1.5) / (274.275 - 1.5)));
  }
  RawDb raw(path);
  CHECK(raw.value("PRAGMA user_version") == "5");
  CHECK(raw.value("PRAGMA journal_mode") == "wal");
  for (const char* table : {"task_sources", "suites", "suite_members", "run_scores", "evaluations",
                            "evaluation_scores"}) {
    INFO(table);
    CHECK(raw.value(std::string("SELECT count(*) FROM sqlite_master WHERE type = 'table' AND "
                                "name = '").append(table).append("'")) == "1");
  }
}

TEST_CASE("the migration steps run in order and every one is needed", "[registry]") {
  CHECK_THROWS_AS(registry::migration_sql(0), Error);
  CHECK_THROWS_AS(registry::migration_sql(registry::schema_version() + 1), Error);
  // a new file runs every step: its schema equals version 1's followed by steps 2 and 3
  RegTempDir dir;
  { Registry reg(dir.file("new.sqlite")); }
  {
    RawDb raw(dir.file("by_hand.sqlite"));
    for (int v = 1; v <= registry::schema_version(); ++v) raw.exec(registry::migration_sql(v));
  }
  RawDb a(dir.file("new.sqlite")), b(dir.file("by_hand.sqlite"));
  const std::string q = "SELECT sql FROM sqlite_master WHERE sql IS NOT NULL ORDER BY name";
  CHECK(a.column(q) == b.column(q));
  // 11 tables, sqlite_sequence (of AUTOINCREMENT) and 5 indices
  CHECK(a.column(q).size() == 17);
}

TEST_CASE("a registry of a newer schema version is refused and left untouched", "[registry]") {
  RegTempDir dir;
  const std::string path = dir.file("future.sqlite");
  {
    RawDb raw(path);
    raw.exec("CREATE TABLE tasks (id TEXT PRIMARY KEY, hologram BLOB); PRAGMA user_version = 6");
  }
  const std::string before = read_file(path);
  const std::string msg = error_of([&] { Registry reg(path); });
  CHECK_THAT(msg, Catch::Contains(path));
  CHECK_THAT(msg, Catch::Contains("schema version 6 is newer"));
  CHECK_THAT(msg, Catch::Contains("(5)"));
  CHECK(read_file(path) == before);
  RawDb raw(path);
  CHECK(raw.value("PRAGMA user_version") == "6");
}

TEST_CASE("a file that is not an SQLite registry is refused, naming it", "[registry]") {
  RegTempDir dir;
  const std::string path = dir.file("notes.sqlite");
  std::string text;
  for (int i = 0; i < 200; ++i) text.append("these are my notes, not a database\n");
  write_file_atomic(path, text);
  std::string msg = error_of([&] { Registry reg(path); });
  CHECK_THAT(msg, Catch::Contains(path));
  CHECK_THAT(msg, Catch::Contains("not a bidex registry"));
  CHECK(read_file(path) == text);
  CHECK_FALSE(file_exists(path + "-wal"));

  // an SQLite file of something else
  const std::string other = dir.file("other.sqlite");
  {
    RawDb raw(other);
    raw.exec("CREATE TABLE recipes (name TEXT)");
  }
  msg = error_of([&] { Registry reg(other); });
  CHECK_THAT(msg, Catch::Contains(other));
  CHECK_THAT(msg, Catch::Contains("recipes"));
  RawDb raw(other);
  CHECK(raw.value("SELECT count(*) FROM sqlite_master WHERE name = 'tasks'") == "0");
  CHECK(raw.value("PRAGMA journal_mode") == "delete");  // not switched to WAL either
}

TEST_CASE("two processes recording 200 runs each at once lose nothing", "[registry]") {
  RegTempDir dir;
  const std::string path = dir.file("shared.sqlite");
  constexpr int kRuns = 200;
  int ready[2], go[2];
  REQUIRE(::pipe(ready) == 0);
  REQUIRE(::pipe(go) == 0);
  pid_t pids[2];
  for (int k = 0; k < 2; ++k) {
    pids[k] = ::fork();
    REQUIRE(pids[k] >= 0);
    if (pids[k] == 0) {
      // child: open the registry (both children create it at once), say so, wait for the start
      // signal, record runs; the exit status says whether everything went through
      int status = 0;
      try {
        ::close(ready[0]);
        ::close(go[1]);
        Registry reg(path);
        if (::write(ready[1], "r", 1) != 1) status = 3;
        ::close(ready[1]);
        char c;
        if (::read(go[0], &c, 1) != 0) status = 3;  // EOF is the signal
        for (int i = 0; i < kRuns; ++i) {
          registry::RunRecord r;
          r.algo = "ppo";
          r.task = k == 0 ? "hand_over" : "catch_underarm";
          r.seed = static_cast<uint64_t>(1000 * k + i);
          const int64_t id = reg.begin_run(r);
          ::usleep(200);  // "training": the other writer gets the processor and the lock
          r.steps = i;
          r.final_return = i;
          reg.finish_run(id, r, {{r.task, "", static_cast<double>(i), 0.5, 1}});
          ::usleep(200);
          if (i % 20 == 0)  // a write that reads first
            reg.set_reference({k == 0 ? "pen" : "switch", "random", static_cast<double>(i),
                               "concurrency test"});
        }
      } catch (const std::exception& e) {
        std::fprintf(stderr, "writer %d: %s\n", k, e.what());
        status = 1;
      }
      ::_exit(status);
    }
  }
  ::close(ready[1]);
  ::close(go[0]);
  char buf[2];
  size_t got = 0;
  while (got < 2) {  // both opened (EOF early: a writer failed to open; it is reported below)
    const ssize_t n = ::read(ready[0], buf + got, 2 - got);
    if (n <= 0) break;
    got += static_cast<size_t>(n);
  }
  ::close(ready[0]);
  ::close(go[1]);  // both start now
  for (int k = 0; k < 2; ++k) {
    int st = 0;
    REQUIRE(::waitpid(pids[k], &st, 0) == pids[k]);
    INFO("writer " << k);
    CHECK(WIFEXITED(st));
    CHECK(WEXITSTATUS(st) == 0);
  }
  Registry reg(path);
  const auto runs = reg.runs();
  CHECK(runs.size() == 2 * kRuns);
  std::set<int64_t> ids;
  std::set<uint64_t> seeds;
  for (auto& r : runs) {
    ids.insert(r.id);
    seeds.insert(r.seed);
    CHECK(r.status == "finished");
    CHECK(reg.scores(r.id).size() == 1);
  }
  CHECK(ids.size() == 2 * kRuns);
  CHECK(seeds.size() == 2 * kRuns);
  // the writers really overlapped: in id order the runs pass from one writer to the other and
  // back (one writer finishing before the other starts would give one change; the two
  // interleave by the hundreds)
  int changes = 0;
  for (size_t i = 1; i < runs.size(); ++i)
    changes += (runs[i].seed >= 1000) != (runs[i - 1].seed >= 1000);
  INFO("changes of writer in id order: " << changes);
  CHECK(changes >= 10);
  CHECK(*seeds.begin() == 0);
  CHECK(*seeds.rbegin() == 1000 + kRuns - 1);
  CHECK(reg.reference("pen", "random")->value == 180);
  CHECK(reg.reference("switch", "random")->value == 180);
  CHECK(reg.tasks(false).size() == 20);
}

TEST_CASE("the age report: latest score per task, references, normalised, age order",
          "[registry]") {
  RegTempDir dir;
  GroundTruthOnly references(dir);  // the random scores are set here
  Registry reg(dir.file("r.sqlite"));
  reg.set_reference({"hand_over", "random", 2.0, "test"});
  reg.set_reference({"lift_underarm", "random", 432.16, "test"});  // ground truth 1432.16
  auto task_run = [&](const std::string& task, double ret) {
    registry::RunRecord r;
    r.algo = "ppo";
    r.task = task;
    const int64_t id = reg.begin_run(r);
    r.final_return = ret;
    reg.finish_run(id, r, {});  // no per-task scores: the final return stands for the task
    return id;
  };
  task_run("hand_over", 274.275);                        // older: replaced by the next
  const int64_t ho = task_run("hand_over", 138.1375);    // (138.1375 - 2) / 272.275 = 0.5
  const int64_t lift = task_run("lift_underarm", 682.16);  // 250 / 1000 = 0.25
  task_run("catch_underarm", 10);                        // no random score: not normalised
  const auto rep = registry::age_report(reg);
  REQUIRE(rep.rows.size() == 20);
  for (size_t i = 0; i < rep.rows.size(); ++i) CHECK(rep.rows[i].task == paper_tasks_by_age()[i]);
  auto row = [&](const std::string& t) {
    for (auto& r : rep.rows)
      if (r.task == t) return r;
    FAIL("no row " << t);
    return registry::AgeRow{};
  };
  CHECK(row("hand_over").run == ho);
  REQUIRE(row("hand_over").normalised);
  CHECK(*row("hand_over").normalised == Approx(0.5));
  REQUIRE(row("lift_underarm").normalised);
  CHECK(*row("lift_underarm").normalised == Approx(0.25));
  CHECK(row("lift_underarm").run == lift);
  CHECK(*row("catch_underarm").mean_return == 10);
  CHECK_FALSE(row("catch_underarm").normalised);
  CHECK(*row("catch_underarm").ground_truth == Approx(17.8));
  CHECK_FALSE(row("pen").mean_return);
  CHECK(registry::unplotted(rep).size() == 18);
  const std::string svg = registry::age_svg(rep);
  size_t n = 0;
  for (size_t p = svg.find("<circle"); p != std::string::npos; p = svg.find("<circle", p + 1)) ++n;
  CHECK(n == 2);
  CHECK(svg.find(">hand_over<") < svg.find(">lift_underarm<"));
  CHECK(svg.find(">pen<") == std::string::npos);
  CHECK_THAT(svg, Catch::Contains("left out, no normalised score: push_block, pen"));
  CHECK_THROWS_AS(registry::age_report(reg, "", 999), Error);
  CHECK_THROWS_AS(registry::age_report(reg, "MT4"), Error);
}

namespace {

// A finished run of suite ML4 (algorithm promp) in run folder `dir`; returns its id.
int64_t meta_run(Registry& reg, const std::string& dir) {
  registry::RunRecord r;
  r.algo = "promp";
  r.suite = "ML4";
  r.seed = 1;
  r.run_dir = dir;
  const int64_t id = reg.begin_run(r);
  reg.finish_run(id, r, {});
  return id;
}

// An evaluation of ML4's train split: the three members, hand_over under its label.
registry::Evaluation ml4_train_evaluation(int64_t run) {
  registry::Evaluation e;
  e.run_id = run;
  e.split = "train";
  e.adapt_episodes = 1;
  e.adapt_steps = 1;
  e.seed = std::numeric_limits<uint64_t>::max();  // stored as the signed 64-bit pattern
  e.checkpoint = "runs/ml4/checkpoint.pt";
  e.time = "2026-03-04T05:06:07Z";
  e.scores = {{"catch_underarm", "catch_underarm", 1.0, 9.8, 0.0, 0.25, 16},
              {"hand_over_free", "hand_over", 4.0, 12.0, std::nullopt, std::nullopt, 16},
              {"catch_abreast", "", 5.0, 33.4, 0.125, 0.5, 8}};
  return e;
}

}  // namespace

TEST_CASE("meta-RL evaluations round-trip, by run and by id, and runs are found by their folder",
          "[registry]") {
  RegTempDir dir;
  Registry reg(dir.file("r.sqlite"));
  const int64_t first = meta_run(reg, "runs/ml4");
  const int64_t other = meta_run(reg, "runs/other");
  const int64_t again = meta_run(reg, "runs/ml4");  // the same folder trained again

  // run_by_dir: the newest run of the folder, exactly
  REQUIRE(reg.run_by_dir("runs/ml4"));
  CHECK(reg.run_by_dir("runs/ml4")->id == again);
  CHECK(reg.run_by_dir("runs/other")->id == other);
  CHECK(reg.run_by_dir("runs/other")->suite == "ML4");
  CHECK_FALSE(reg.run_by_dir("runs/ml"));
  CHECK_FALSE(reg.run_by_dir("runs/ml4/"));
  CHECK_FALSE(reg.run_by_dir(""));

  CHECK(reg.evaluations().empty());
  const int64_t e1 = reg.add_evaluation(ml4_train_evaluation(first));
  registry::Evaluation test_split;
  test_split.run_id = again;
  test_split.split = "test";
  test_split.adapt_episodes = 3;
  test_split.adapt_steps = 0;
  test_split.scores = {{"two_catch_underarm", "", -1.5, 7.1, 0.0, 1.0, 4}};
  const int64_t e2 = reg.add_evaluation(test_split);
  const int64_t e3 = reg.add_evaluation(ml4_train_evaluation(first));
  CHECK(e1 >= 1);
  CHECK(e2 > e1);
  CHECK(e3 > e2);

  const auto all = reg.evaluations();
  REQUIRE(all.size() == 3);
  CHECK(all[0].id == e1);
  CHECK(all[1].id == e2);
  CHECK(all[2].id == e3);
  const auto& a = all[0];
  CHECK(a.run_id == first);
  CHECK(a.split == "train");
  CHECK(a.adapt_episodes == 1);
  CHECK(a.adapt_steps == 1);
  CHECK(a.seed == std::numeric_limits<uint64_t>::max());
  CHECK(a.checkpoint == "runs/ml4/checkpoint.pt");
  CHECK(a.time == "2026-03-04T05:06:07Z");
  REQUIRE(a.scores.size() == 3);  // in insertion order, not by task or label
  CHECK(a.scores[0].task == "catch_underarm");
  CHECK(a.scores[0].return_before == 1.0);
  CHECK(a.scores[0].return_after == 9.8);
  CHECK(a.scores[0].success_before == 0.0);
  CHECK(a.scores[0].success_after == 0.25);
  CHECK(a.scores[0].episodes == 16);
  CHECK(a.scores[1].task == "hand_over_free");
  CHECK(a.scores[1].label == "hand_over");
  CHECK_FALSE(a.scores[1].success_before);
  CHECK_FALSE(a.scores[1].success_after);
  CHECK(a.scores[2].label == "catch_abreast");  // an empty label is the task id
  CHECK(a.scores[2].success_before == 0.125);

  // an empty time is now; by run; by id
  const auto b = reg.evaluation(e2);
  REQUIRE(b);
  CHECK(b->time.size() == 20);  // 2026-11-22T15:00:00Z
  CHECK(b->time.back() == 'Z');
  CHECK(b->split == "test");
  CHECK(b->adapt_episodes == 3);
  CHECK(b->adapt_steps == 0);
  CHECK(b->checkpoint.empty());
  REQUIRE(b->scores.size() == 1);
  CHECK(b->scores[0].return_before == -1.5);
  CHECK(b->scores[0].success_after == 1.0);
  const auto of_first = reg.evaluations(first);
  REQUIRE(of_first.size() == 2);
  CHECK(of_first[0].id == e1);
  CHECK(of_first[1].id == e3);
  CHECK(of_first[1].scores.size() == 3);
  CHECK(reg.evaluations(again).size() == 1);
  CHECK(reg.evaluations(other).empty());
  CHECK(reg.evaluations(9999).empty());
  CHECK_FALSE(reg.evaluation(9999));
  CHECK_FALSE(reg.evaluation(0));
  // the runs themselves are untouched
  CHECK(reg.runs().size() == 3);
  CHECK(reg.scores(first).empty());
}

TEST_CASE("an evaluation of an unknown run, of a bad split or with bad scores is refused, "
          "naming the value, and nothing is written", "[registry]") {
  RegTempDir dir;
  const std::string path = dir.file("r.sqlite");
  Registry reg(path);
  const int64_t run = meta_run(reg, "runs/ml4");
  const int64_t kept = reg.add_evaluation(ml4_train_evaluation(run));

  registry::Evaluation e = ml4_train_evaluation(run + 41);
  std::string msg = error_of([&] { reg.add_evaluation(e); });
  CHECK_THAT(msg, Catch::Contains(path));
  CHECK_THAT(msg, Catch::Contains("no run with id " + std::to_string(run + 41)));

  e = ml4_train_evaluation(run);
  e.split = "validation";
  msg = error_of([&] { reg.add_evaluation(e); });
  CHECK_THAT(msg, Catch::Contains("split 'validation' is not train or test"));
  e.split = "";
  CHECK_THAT(error_of([&] { reg.add_evaluation(e); }), Catch::Contains("split ''"));

  e = ml4_train_evaluation(run);
  e.scores.push_back({"pen", "hand_over", 1, 2, 0, 0, 1});  // hand_over twice
  CHECK_THAT(error_of([&] { reg.add_evaluation(e); }),
             Catch::Contains("two scores with the label 'hand_over'"));
  e = ml4_train_evaluation(run);
  e.scores[2].return_after = NAN;
  CHECK_THAT(error_of([&] { reg.add_evaluation(e); }),
             Catch::Contains("the return of 'catch_abreast' is not a finite number"));
  e = ml4_train_evaluation(run);
  e.adapt_steps = -1;
  CHECK_THAT(error_of([&] { reg.add_evaluation(e); }), Catch::Contains("steps -1"));

  // nothing half-written: the one good evaluation and its three scores only
  REQUIRE(reg.evaluations().size() == 1);
  CHECK(reg.evaluations()[0].id == kept);
  RawDb raw(path);
  CHECK(raw.value("SELECT count(*) FROM evaluations") == "1");
  CHECK(raw.value("SELECT count(*) FROM evaluation_scores") == "3");
  // a later good one still gets the next id
  CHECK(reg.add_evaluation(ml4_train_evaluation(run)) == kept + 1);
}

TEST_CASE("a version-2 file with runs is migrated to version 3: runs kept, evaluations added",
          "[registry]") {
  RegTempDir dir;
  const std::string path = dir.file("v2.sqlite");
  {
    RawDb raw(path);
    raw.exec(registry::migration_sql(1));
    raw.exec(registry::migration_sql(2));
    raw.exec("PRAGMA user_version = 2");
    // a version-2 registry: a suite run with per-task scores and a task run
    raw.exec(
        "INSERT INTO tasks VALUES ('catch_underarm', 1, 'Catch Underarm', "
        "'ShadowHandCatchUnderarm', 48, 48, '48', 'hard', 'catch', 417, 52, 'builtin');"
        "INSERT INTO runs (algo, task, suite, seed, steps, run_dir, started, finished, status, "
        "final_return) VALUES ('promp', '', 'ML4', 5, 2000, 'runs/ml4', '2026-02-01T00:00:00Z', "
        "'2026-02-01T02:00:00Z', 'finished', 11.5);"
        "INSERT INTO run_scores VALUES (1, 'catch_underarm', 'catch_underarm', 11.5, 0.5, 20, 0);"
        "INSERT INTO runs (algo, task, seed, started, status) VALUES ('ppo', 'catch_underarm', 6, "
        "'2026-02-02T00:00:00Z', 'running');");
    CHECK(raw.value("SELECT count(*) FROM sqlite_master WHERE name = 'evaluations'") == "0");
  }
  {
    Registry reg(path);
    const auto runs = reg.runs();
    REQUIRE(runs.size() == 2);
    CHECK(runs[0].id == 1);
    CHECK(runs[0].suite == "ML4");
    CHECK(runs[0].seed == 5);
    CHECK(runs[0].steps == 2000);
    CHECK(runs[0].final_return == 11.5);
    CHECK(runs[0].finished == "2026-02-01T02:00:00Z");
    CHECK(runs[1].status == "running");
    REQUIRE(reg.scores(1).size() == 1);
    CHECK(reg.scores(1)[0].success == 0.5);
    CHECK(reg.run_by_dir("runs/ml4")->id == 1);
    // the new tables work for the old run, and new runs go on from the old ids
    CHECK(reg.evaluations().empty());
    const int64_t e = reg.add_evaluation(ml4_train_evaluation(1));
    CHECK(e == 1);
    CHECK(reg.evaluation(e)->scores.size() == 3);
    registry::RunRecord r;
    r.algo = "ppo";
    r.task = "pen";
    CHECK(reg.begin_run(r) == 3);
  }
  RawDb raw(path);
  CHECK(raw.value("PRAGMA user_version") == "5");
  for (const char* table : {"evaluations", "evaluation_scores"}) {
    INFO(table);
    CHECK(raw.value(std::string("SELECT count(*) FROM sqlite_master WHERE type = 'table' AND "
                                "name = '").append(table).append("'")) == "1");
  }
  CHECK(raw.value("SELECT count(*) FROM sqlite_master WHERE type = 'index' AND "
                  "name = 'evaluations_run'") == "1");
  // evaluation_scores.evaluation is a foreign key to evaluations
  CHECK(raw.value("SELECT \"table\" FROM pragma_foreign_key_list('evaluation_scores')") ==
        "evaluations");
}

TEST_CASE("the age report of an evaluation: the scores after adaptation, normalised like a run's",
          "[registry]") {
  RegTempDir dir;
  GroundTruthOnly references(dir);  // the random scores are set here
  Registry reg(dir.file("r.sqlite"));
  reg.set_reference({"catch_underarm", "random", 1.8, "test"});     // ground truth 17.8
  reg.set_reference({"catch_abreast", "random", 3.4, "test"});      // ground truth 43.4
  reg.set_reference({"two_catch_underarm", "random", 0.1, "test"}); // ground truth 14.1
  meta_run(reg, "runs/other");  // run 1: ids of runs and evaluations differ
  const int64_t run = meta_run(reg, "runs/ml4");
  const int64_t id = reg.add_evaluation(ml4_train_evaluation(run));

  const auto rep = registry::age_report_evaluation(reg, id);
  CHECK(rep.source == "evaluation 1 of run 2 (promp on ML4, split train, after 1 adaptation "
                      "episode and 1 gradient step)");
  // by age: catch_abreast and hand_over_free (a registered variant, hand_over's 9-10 months; ids
  // in order), then catch_underarm (48)
  REQUIRE(rep.rows.size() == 3);
  CHECK(rep.rows[0].label == "catch_abreast");
  CHECK(rep.rows[1].label == "hand_over");
  CHECK(rep.rows[1].task == "hand_over_free");
  CHECK(rep.rows[1].registered);
  CHECK(rep.rows[1].age_text == "9-10");
  CHECK(rep.rows[2].label == "catch_underarm");
  for (auto& r : rep.rows) CHECK(r.run == run);
  // after adaptation, by hand: (33.4 - 3.4) / (43.4 - 3.4) = 0.75; (9.8 - 1.8) / 16 = 0.5
  CHECK(*rep.rows[0].mean_return == 33.4);
  CHECK(*rep.rows[0].success == 0.5);
  CHECK(*rep.rows[0].random == Approx(3.4));
  CHECK(*rep.rows[0].ground_truth == Approx(43.4));
  CHECK(*rep.rows[0].normalised == Approx(0.75));
  CHECK(rep.rows[0].age_text == "9-10");
  CHECK(*rep.rows[2].mean_return == 9.8);
  CHECK(*rep.rows[2].success == 0.25);
  CHECK(*rep.rows[2].normalised == Approx(0.5));
  CHECK(*rep.rows[1].mean_return == 12.0);
  CHECK_FALSE(rep.rows[1].success);
  CHECK_FALSE(rep.rows[1].normalised);  // a ground truth, but no random score here
  CHECK(registry::unplotted(rep) == std::vector<std::string>{"hand_over"});

  // the test split, adapted in memory only (0 gradient steps): (7.1 - 0.1) / 14 = 0.5
  registry::Evaluation t;
  t.run_id = run;
  t.split = "test";
  t.adapt_episodes = 2;
  t.scores = {{"two_catch_underarm", "", -3.0, 7.1, 0.0, 1.0, 4}};
  const auto rt = registry::age_report_evaluation(reg, reg.add_evaluation(t));
  CHECK(rt.source == "evaluation 2 of run 2 (promp on ML4, split test, after 2 adaptation "
                     "episodes and 0 gradient steps)");
  REQUIRE(rt.rows.size() == 1);
  CHECK(*rt.rows[0].normalised == Approx(0.5));
  CHECK(*rt.rows[0].success == 1.0);

  // the run's report (report age --run) is its newest test-split evaluation's, after adaptation
  const auto by_run = registry::age_report(reg, "", run);
  CHECK(by_run.source == rt.source);
  REQUIRE(by_run.rows.size() == 1);
  CHECK(*by_run.rows[0].normalised == Approx(0.5));
  // a run without evaluations reports its own scores (run 1 recorded none: an error)
  CHECK_THROWS_AS(registry::age_report(reg, "", 1), Error);
  CHECK_THAT(error_of([&] { registry::age_report_evaluation(reg, 77); }),
             Catch::Contains("no evaluation with id 77"));
  registry::Evaluation empty = t;
  empty.scores.clear();
  const int64_t none = reg.add_evaluation(empty);
  CHECK_THAT(error_of([&] { registry::age_report_evaluation(reg, none); }),
             Catch::Contains("evaluation 3 recorded no scores"));
}

TEST_CASE("datasets and the offline normalised score: the dataset's references, a replay "
          "dataset's from its task's newest with both", "[registry][offline]") {
  RegTempDir dir;
  const std::string path = dir.file("reg.sqlite");
  {
    RawDb raw(path);  // a version-3 file with a run: migrated, the run has no dataset
    for (int v = 1; v <= 3; ++v) raw.exec(registry::migration_sql(v));
    raw.exec("PRAGMA user_version = 3;"
             "INSERT INTO runs (algo, task, seed, started, status) VALUES ('ppo', 'hand_over', 1, "
             "'2026-02-02T00:00:00Z', 'finished');");
  }
  Registry reg(path);
  CHECK(reg.run(1)->dataset.empty());
  registry::DatasetRecord expert;
  expert.checksum = "sha256:" + std::string(64, 'a');
  expert.dataset_id = "hand_over/expert-v0";
  expert.task = "hand_over";
  expert.quality = "expert";
  expert.path = "/data/hand_over/expert-v0";
  expert.total_steps = 1000;
  expert.total_episodes = 10;
  expert.ref_min = 2.0;
  expert.ref_max = 32.0;
  expert.added = "2026-03-01T00:00:00Z";
  reg.put_dataset(expert);
  registry::DatasetRecord replay = expert;
  replay.checksum = "sha256:" + std::string(64, 'b');
  replay.quality = "replay";
  replay.ref_min.reset();
  replay.ref_max.reset();
  reg.put_dataset(replay);
  // (17 - 2) / (32 - 2) = 0.5 on the paper's scale
  CHECK(*reg.offline_normalised(expert.checksum, 17.0) == Approx(50.0));
  CHECK(*reg.offline_normalised(replay.checksum, 2.0) == Approx(0.0));
  CHECK_FALSE(reg.offline_normalised("sha256:" + std::string(64, 'c'), 17.0));
  // a newer expert of the task with other references is the replay dataset's
  registry::DatasetRecord newer = expert;
  newer.checksum = "sha256:" + std::string(64, 'd');
  newer.ref_max = 12.0;
  newer.added = "2026-04-01T00:00:00Z";
  reg.put_dataset(newer);
  CHECK(*reg.offline_normalised(replay.checksum, 7.0) == Approx(50.0));
  CHECK(*reg.offline_normalised(expert.checksum, 17.0) == Approx(50.0));  // its own kept
  // the same checksum again replaces the row (a moved folder)
  expert.path = "/elsewhere";
  reg.put_dataset(expert);
  CHECK(reg.datasets().size() == 3);
  CHECK(reg.dataset(expert.checksum)->path == "/elsewhere");
  CHECK(reg.dataset(expert.checksum)->total_episodes == 10);
  // a run of a dataset keeps its checksum
  registry::RunRecord r;
  r.algo = "td3bc";
  r.task = "hand_over";
  r.dataset = expert.checksum;
  const int64_t id = reg.begin_run(r);
  CHECK(reg.run(id)->dataset == expert.checksum);
  // no checksum, or no task: refused
  registry::DatasetRecord bad = expert;
  bad.checksum = "md5:00";
  CHECK_THROWS_AS(reg.put_dataset(bad), Error);
  bad = expert;
  bad.task.clear();
  CHECK_THROWS_AS(reg.put_dataset(bad), Error);
}
