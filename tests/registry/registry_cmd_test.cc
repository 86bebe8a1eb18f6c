// apps/cmd_registry: `bidex registry list | add-task | scores | evals | reference | report age`,
// run as the real binary on temp registries.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "core/files.h"
#include "registry/registry.h"
#include "tests/registry/registry_fixture.h"
#include "tests/run_command.h"

using namespace bidex;
using namespace bidex::test;
using registry::Registry;

namespace {

std::string q(const std::string& s) {
  std::string out = "'";
  out.append(s).append("'");
  return out;
}

// `bidex registry ARGS --registry PATH`
CommandResult reg_run(const std::string& args, const std::string& path) {
  std::string a = "registry ";
  a.append(args).append(" --registry ").append(q(path));
  return bidex_run(a);
}

// Positions of the ids in `out` (each must appear) are increasing.
void check_order(const std::string& out, const std::vector<std::string>& ids) {
  size_t last = 0;
  for (auto& id : ids) {
    INFO("id " << id);
    // a table line starts with the id followed by a space
    const size_t at = out.find("\n" + id + " ");
    REQUIRE(at != std::string::npos);
    CHECK(at > last);
    last = at;
  }
}

// The example task file of the README, edited: `from` replaced by `to` (once).
std::string edited_example(const std::string& from, const std::string& to) {
  std::string text = read_file(std::string(BIDEX_SOURCE_DIR) + "/configs/registry/example_task.yaml");
  if (from.empty()) return text;
  const size_t at = text.find(from);
  INFO("editing the example: looking for '" << from << "'");
  REQUIRE(at != std::string::npos);
  REQUIRE(text.find(from, at + 1) == std::string::npos);
  return text.replace(at, from.size(), to);
}

}  // namespace

TEST_CASE("bidex registry list: the paper's tasks, by age with --by age", "[registry][apps]") {
  RegTempDir dir;
  const std::string path = dir.file("r.sqlite");
  CommandResult r = reg_run("list --by age", path);
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK(has_text(r.out, "20 tasks, by human age"));
  check_order(r.out, paper_tasks_by_age());
  CHECK(has_text(r.out, "\nhand_over "));
  // columns: id, age, difficulty, obs, act, random, ground truth (configs/registry/
  // references.yaml, 4 significant digits), origin
  CHECK(has_row(r.out, {"id", "age", "difficulty", "obs", "act", "random", "ground_truth",
                        "origin"}));
  CHECK(has_row(r.out, {"two_catch_underarm", "adult", "hard", "446", "52", "1.601", "14.1",
                        "builtin"}));
  CHECK(has_row(r.out, {"push_block", "5-6", "easy", "417", "52", "231.8", "602.1", "builtin"}));
  CHECK(has_row(r.out, {"grasp_and_place", "22-28", "medium", "425", "52", "17.22", "434.5",
                        "builtin"}));
  CHECK(!has_text(r.out, " - "));  // every task has both references

  r = reg_run("list", path);
  REQUIRE(r.rc == 0);
  check_order(r.out, {"hand_over", "catch_underarm", "catch_over2underarm", "catch_abreast",
                      "two_catch_underarm", "lift_underarm", "door_open_outward"});
  r = reg_run("list --by colour", path);
  CHECK(r.rc == 2);
  CHECK(has_text(r.out, "--by takes 'age'"));
}

TEST_CASE("bidex registry add-task: the README's example registers in age order",
          "[registry][apps]") {
  RegTempDir dir;
  const std::string path = dir.file("r.sqlite");
  // exactly as the README writes it, from the source tree
  std::string cmd = "cd ";
  cmd.append(q(BIDEX_SOURCE_DIR)).append(" && ").append(q(BIDEX_BINARY));
  cmd.append(" registry add-task configs/registry/example_task.yaml --registry ").append(q(path));
  CommandResult r = run_command(cmd);
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK(has_text(r.out, "registered example_bimanual_pour"));
  r = reg_run("list --by age", path);
  REQUIRE(r.rc == 0);
  CHECK(has_text(r.out, "21 tasks"));
  // 24-30 months: after block_stack and grasp_and_place (22-28), before bottle_cap (30)
  check_order(r.out, {"grasp_and_place", "example_bimanual_pour", "bottle_cap"});
  CHECK(has_text(r.out, std::string(BIDEX_SOURCE_DIR) + "/configs/registry/example_task.yaml"));
  Registry reg(path);
  const auto t = reg.task("example_bimanual_pour");
  REQUIRE(t);
  CHECK(t->age_min == 24);
  CHECK(t->age_max == 30);
  CHECK(t->original_name == "ShadowHandExamplePour");
  CHECK(t->sources.at("age") == "example: a developmental-milestone table");
  CHECK(t->sources.size() == 3);

  // the same id again: refused, naming the file and the key
  r = reg_run("add-task " + q(std::string(BIDEX_SOURCE_DIR) + "/configs/registry/example_task.yaml"),
              path);
  CHECK(r.rc == 2);
  CHECK(has_text(r.out, "example_task.yaml: id: expected an id not registered yet, got "
                        "'example_bimanual_pour', already registered"));
}

TEST_CASE("bidex registry add-task refuses a bad file with exit 2, naming file and key, and "
          "writes nothing", "[registry][apps]") {
  RegTempDir dir;
  const std::string path = dir.file("r.sqlite");
  struct Case {
    const char* what;
    std::string from, to;
    const char* key;       // in the message as "FILE[:LINE]: KEY: expected ..."
    const char* expected;
    const char* actual;
  };
  const std::vector<Case> cases = {
      {"unknown key", "skill:", "colour: red\nskill:", "colour", "one of the keys",
       "unknown key 'colour'"},
      {"missing field", "skill: pour from a cup held in one hand into a cup held in the other\n",
       "", "skill", "a value for the required key", "none"},
      {"wrong type", "obs_dim: 428", "obs_dim: many", "obs_dim", "an integer", "'many'"},
      {"age max below min", "max: 30", "max: 12", "age.max", "a number of months >= age.min (24)",
       "'12'"},
      {"negative dimension", "act_dim: 52", "act_dim: -52", "act_dim", "an action width >= 1",
       "'-52'"},
      {"unknown difficulty", "difficulty: medium", "difficulty: trivial", "difficulty",
       "easy, medium or hard", "'trivial'"},
      {"no source of the age", "  age: \"example: a developmental-milestone table\"\n", "",
       "sources.age", "a value for the required key", "none"},
      {"duplicate id", "id: example_bimanual_pour", "id: door_open_inward", "id",
       "an id not registered yet", "'door_open_inward', already registered (origin builtin)"},
  };
  // first without a registry file: a bad file creates none
  {
    const std::string file = dir.file("bad.yaml");
    write_file_atomic(file, edited_example("obs_dim: 428", "obs_dim: many"));
    CommandResult r = reg_run("add-task " + q(file), path);
    INFO(r.out);
    CHECK(r.rc == 2);
    CHECK_FALSE(file_exists(path));
  }
  { Registry reg(path); }
  const std::string before = reg_run("list", path).out;
  for (auto& c : cases) {
    INFO(c.what);
    const std::string file = dir.file(std::string(c.what).append(".yaml"));
    write_file_atomic(file, edited_example(c.from, c.to));
    CommandResult r = reg_run("add-task " + q(file), path);
    INFO(r.out);
    CHECK(r.rc == 2);
    CHECK(has_text(r.out, "bidex: error: " + file));
    CHECK(has_text(r.out, std::string(": ").append(c.key).append(": expected ")));
    CHECK(has_text(r.out, std::string("expected ").append(c.expected)));
    CHECK(has_text(r.out, std::string("got ").append(c.actual)));
    CHECK(reg_run("list", path).out == before);
  }
  CommandResult r = reg_run("add-task " + q(dir.file("missing.yaml")), path);
  CHECK(r.rc == 2);
  CHECK(has_text(r.out, dir.file("missing.yaml")));
  r = reg_run("add-task", path);
  CHECK(r.rc == 2);
  Registry reg(path);
  CHECK(reg.tasks(false).size() == 20);
}

TEST_CASE("bidex registry reference and scores", "[registry][apps]") {
  RegTempDir dir;
  GroundTruthOnly references(dir);  // the random scores are set here
  const std::string path = dir.file("r.sqlite");
  CommandResult r = reg_run(
      "reference --task hand_over --kind random --value 2 --source 'a random policy'", path);
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK(has_text(r.out, "hand_over random = 2 (a random policy)"));
  CHECK(reg_run("reference --task hand_over --kind expert --value 2 --source x", path).rc == 2);
  CHECK(reg_run("reference --task no_such --kind random --value 2 --source x", path).rc == 2);
  r = reg_run("reference --task hand_over --kind random --source x", path);
  CHECK(r.rc == 2);
  CHECK(has_text(r.out, "missing --value"));
  {
    Registry reg(path);
    CHECK(reg.reference("hand_over", "random")->source == "a random policy");
    registry::RunRecord run;
    run.algo = "ppo";
    run.task = "hand_over";
    run.seed = 3;
    run.run_dir = "runs/ho";
    const int64_t id = reg.begin_run(run);
    run.steps = 1000000;
    run.final_return = 138.1375;
    run.final_success = 0.25;
    reg.finish_run(id, run, {{"hand_over", "", 138.1375, 0.25, 64}});
    registry::RunRecord s;
    s.algo = "mtppo";
    s.suite = "MT4";
    const int64_t sid = reg.begin_run(s);
    reg.finish_run(sid, s, {{"catch_underarm", "", 8.9, 0.1, 10}, {"hand_over", "", 70.06875, 0.0, 12}});
  }
  r = reg_run("scores", path);
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK(has_text(r.out, "run 1  ppo  hand_over  seed 3  1000000 steps  finished"));
  CHECK(has_text(r.out, "final return 138.1 (normalised 0.500)  success 0.250"));
  CHECK(has_text(r.out, "run 2  mtppo  suite MT4"));
  // per-task scores: (70.06875 - 2) / (274.275 - 2) = 0.25; catch_underarm has no random score
  CHECK(has_row(r.out, {"label", "task", "return", "success", "episodes", "normalised"}));
  CHECK(has_row(r.out, {"hand_over", "hand_over", "138.1", "0.250", "64", "0.500"}));
  CHECK(has_row(r.out, {"hand_over", "hand_over", "70.07", "0.000", "12", "0.250"}));
  CHECK(has_row(r.out, {"catch_underarm", "catch_underarm", "8.9", "0.100", "10", "-"}));
  CHECK(has_text(r.out, "2 runs in"));
  r = reg_run("scores --suite MT4", path);
  CHECK(has_text(r.out, "1 run in"));
  CHECK_FALSE(has_text(r.out, "run 1 "));
  r = reg_run("scores --task catch_underarm", path);
  CHECK(has_text(r.out, "run 2 "));
  CHECK(has_text(r.out, "1 run in"));
}

TEST_CASE("bidex registry report age: the table and one plotted point per normalised task, "
          "in age order", "[registry][apps]") {
  RegTempDir dir;
  GroundTruthOnly references(dir);  // the random scores are set here
  TimeToGoalWithOneNotMet sweep(dir, "re_orientation");  // the legend of a goal not met
  const std::string path = dir.file("sub/r.sqlite");
  int64_t suite_run = 0;
  {
    Registry reg(path);
    // random scores for four of the seven tasks with a ground truth
    reg.set_reference({"hand_over", "random", 2.0, "test"});            // ground truth 274.275
    reg.set_reference({"catch_abreast", "random", 3.4, "test"});        // 43.4
    reg.set_reference({"scissors", "random", 11.625, "test"});          // 611.625
    reg.set_reference({"two_catch_underarm", "random", 0.1, "test"});   // 14.1
    auto task_run = [&](const std::string& task, double ret) {
      registry::RunRecord r;
      r.algo = "ppo";
      r.task = task;
      const int64_t id = reg.begin_run(r);
      r.final_return = ret;
      reg.finish_run(id, r, {{task, "", ret, 0.5, 10}});
    };
    task_run("two_catch_underarm", 14.1);  // 1
    task_run("hand_over", 138.1375);       // 0.5
    task_run("catch_abreast", 13.4);       // 0.25
    task_run("scissors", 461.625);         // 0.75
    task_run("catch_underarm", 10);        // no random score
    task_run("pen", 5);                    // no random score
    registry::RunRecord s;
    s.algo = "mtppo";
    s.suite = "MT4";
    suite_run = reg.begin_run(s);
    reg.finish_run(suite_run, s,
                   {{"two_catch_underarm", "", 7.1, 0.0, 5}, {"hand_over", "", 274.275, 1.0, 5},
                    {"catch_underarm", "", 3, 0.0, 5}});
  }
  // every task, each with its latest score (the suite run is the latest for three of them)
  CommandResult r = reg_run("report age", path);
  INFO(r.out);
  REQUIRE(r.rc == 0);
  check_order(r.out, paper_tasks_by_age());
  CHECK(has_row(r.out, {"task", "age", "difficulty", "run", "return", "random", "ground_truth",
                        "normalised"}));
  // task, age, difficulty, run, return, random, ground truth, normalised (by hand)
  CHECK(has_row(r.out, {"hand_over", "9-10", "easy", "7", "274.3", "2", "274.3", "1.000"}));
  CHECK(has_row(r.out, {"catch_abreast", "9-10", "easy", "3", "13.4", "3.4", "43.4", "0.250"}));
  CHECK(has_row(r.out, {"scissors", "7", "easy", "4", "461.6", "11.62", "611.6", "0.750"}));
  CHECK(has_row(r.out, {"two_catch_underarm", "adult", "hard", "7", "7.1", "0.1", "14.1",
                        "0.500"}));
  CHECK(has_row(r.out, {"catch_underarm", "48", "hard", "7", "3", "-", "17.8", "-"}));
  CHECK(has_row(r.out, {"pen", "7", "easy", "6", "5", "-", "421.5", "-"}));
  CHECK(has_row(r.out, {"lift_underarm", "12", "easy", "-", "-", "-", "1432", "-"}));
  CHECK(has_row(r.out, {"door_open_outward", "13", "easy", "-", "-", "-", "580", "-"}));
  CHECK(has_text(r.out, "left out of the plot (no normalised score): push_block, pen, "
                        "catch_over2underarm"));
  CHECK(has_text(r.out, "plot (4 of 20 tasks)"));
  // the sweep's time to each goal, below the scores: task, age, goal, target, slot-steps, wall
  // seconds, how it was met, slot-steps trained (configs/registry/time_to_goal.yaml)
  CHECK(has_row(r.out, {"task", "age", "goal", "target", "slot-steps", "wall_s", "by", "trained"}));
  CHECK(has_row(r.out, {"catch_abreast", "9-10", "original_final", "43.4", "24.6M", "123",
                        "training", "100.0M"}));
  CHECK(has_row(r.out, {"re_orientation", "18", "success", "0.8", "-", "-", "not_reached",
                        "50.1M"}));
  const std::string svg_file = dir.file("sub/age_report.svg");  // beside the registry
  REQUIRE(file_exists(svg_file));
  const std::string whole = read_file(svg_file);
  // two panels: the scores, then the PPO sweep's slot-steps to each goal (one point per task of
  // configs/registry/time_to_goal.yaml)
  const size_t second = whole.find("PPO sweep: slot-steps to each task");
  REQUIRE(second != std::string::npos);
  const std::string svg = whole.substr(0, second);
  size_t goal_points = 0;
  for (size_t p = whole.find("<circle cx=\"", second); p != std::string::npos;
       p = whole.find("<circle cx=\"", p + 1))
    ++goal_points;
  CHECK(goal_points == 20);
  CHECK(has_text(whole, "not met (at least: the slot-steps trained)"));
  // one point per task with both references and a score, labelled, in age order, x increasing
  std::vector<std::string> labels;
  std::vector<double> xs;
  for (size_t p = svg.find("<circle cx=\""); p != std::string::npos;
       p = svg.find("<circle cx=\"", p + 1)) {
    xs.push_back(std::stod(svg.substr(p + 12)));
    const size_t t = svg.find("font-size=\"10\">", p);
    REQUIRE(t != std::string::npos);
    const size_t b = t + 15;
    labels.push_back(svg.substr(b, svg.find('<', b) - b));
  }
  CHECK(labels == std::vector<std::string>{"scissors", "catch_abreast", "hand_over",
                                           "two_catch_underarm"});
  REQUIRE(xs.size() == 4);
  CHECK(xs[0] < xs[1]);
  CHECK(xs[1] == xs[2]);  // both at 9-10 months
  CHECK(xs[2] < xs[3]);
  CHECK(has_text(svg, "left out, no normalised score: push_block, pen"));
  // beside the plot: the printed table as text, and the plot as a PNG (rsvg-convert, which
  // scripts/setup.sh installs), or a line saying how to get one
  const std::string txt = read_file(dir.file("sub/age_report.txt"));
  CHECK(r.out.rfind(txt, 0) == 0);  // the table and the left-out line, as printed
  CHECK(has_row(txt, {"scissors", "7", "easy", "4", "461.6", "11.62", "611.6", "0.750"}));
  CHECK(has_text(r.out, "table: " + dir.file("sub/age_report.txt")));
  if (run_command("command -v rsvg-convert").rc == 0) {
    CHECK(has_text(r.out, "png: " + dir.file("sub/age_report.png")));
    CHECK(read_file(dir.file("sub/age_report.png")).rfind("\x89PNG\r\n", 0) == 0);
  } else {
    WARN("rsvg-convert is not installed: the PNG is not checked");
  }
  const CommandResult no_rsvg = run_command(std::string("PATH=/nonexistent '") + BIDEX_BINARY +
                                            "' registry report age --registry " + q(path) +
                                            " --out " + q(dir.file("bare.svg")));
  CHECK(no_rsvg.rc == 0);
  CHECK(has_text(no_rsvg.out, "rsvg-convert is not on PATH: no PNG of " + dir.file("bare.svg") +
                                  " (apt-get install librsvg2-bin)"));
  CHECK(file_exists(dir.file("bare.txt")));
  CHECK_FALSE(file_exists(dir.file("bare.png")));

  // the suite's latest run only, to a chosen file
  const std::string out = dir.file("suite.svg");
  r = reg_run("report age --suite MT4 --out " + q(out), path);
  REQUIRE(r.rc == 0);
  CHECK(has_text(r.out, "scores of suite MT4, its latest scored run 7 (mtppo)"));
  CHECK(has_text(r.out, "plot (2 of 3 tasks)"));
  check_order(r.out, {"hand_over", "catch_underarm", "two_catch_underarm"});
  // (the sweep's goal table below the scores lists every task)
  CHECK_FALSE(has_text(r.out.substr(0, r.out.find("the PPO sweep's time")), "\npen "));
  REQUIRE(file_exists(out));
  // the same run by id
  r = reg_run("report age --run " + std::to_string(suite_run) + " --out " + q(out), path);
  REQUIRE(r.rc == 0);
  CHECK(has_text(r.out, "scores of run 7 (mtppo, suite MT4)"));
  r = reg_run("report age --run 4 --out " + q(out), path);
  REQUIRE(r.rc == 0);
  CHECK(has_text(r.out, "\nscissors "));
  CHECK(has_text(r.out, "plot (1 of 1 tasks)"));
  // bad choices: exit 2
  CHECK(reg_run("report age --run 99", path).rc == 2);
  CHECK(reg_run("report age --suite ML20", path).rc == 2);
  CHECK(reg_run("report age --suite MT4 --run 7", path).rc == 2);
}

TEST_CASE("bidex registry evals and report age --eval: scores before and after adaptation",
          "[registry][apps]") {
  RegTempDir dir;
  GroundTruthOnly references(dir);  // the random scores are set here
  const std::string path = dir.file("r.sqlite");
  int64_t run = 0, other = 0;
  {
    Registry reg(path);
    reg.set_reference({"catch_underarm", "random", 1.8, "test"});  // ground truth 17.8
    reg.set_reference({"catch_abreast", "random", 3.4, "test"});   // ground truth 43.4
    registry::RunRecord r;
    r.algo = "promp";
    r.suite = "ML4";
    r.run_dir = "runs/ml4";
    run = reg.begin_run(r);
    r.algo = "maml";
    other = reg.begin_run(r);
    registry::Evaluation e;
    e.run_id = run;
    e.split = "train";
    e.adapt_episodes = 1;
    e.adapt_steps = 1;
    e.seed = 9;
    e.checkpoint = "runs/ml4/checkpoint.pt";
    e.time = "2026-03-04T05:06:07Z";
    e.scores = {{"catch_underarm", "", 1.0, 9.8, 0.0, 0.25, 16},
                {"hand_over_free", "hand_over", 4.0, 12.0, std::nullopt, std::nullopt, 16},
                {"catch_abreast", "", 5.0, 33.4, 0.125, 0.5, 8}};
    reg.add_evaluation(e);
    e.run_id = other;
    e.split = "test";
    e.adapt_episodes = 2;
    e.adapt_steps = 3;
    e.checkpoint.clear();
    e.scores = {{"two_catch_underarm", "", 0.5, 1.5, 0.0, 0.0, 4}};
    reg.add_evaluation(e);
  }
  CommandResult r = reg_run("evals", path);
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK(has_text(r.out, "evaluation 1  run 1 (promp, suite ML4)  split train  after 1 adaptation "
                        "episode and 1 gradient step  seed 9  2026-03-04T05:06:07Z"));
  CHECK(has_text(r.out, "checkpoint runs/ml4/checkpoint.pt"));
  CHECK(has_row(r.out, {"label", "task", "return", "before", "->", "after", "success", "before",
                        "->", "after", "episodes", "normalised"}));
  // label, task, return before -> after, success before -> after, episodes, normalised after:
  // (9.8 - 1.8) / 16 = 0.5, (33.4 - 3.4) / 40 = 0.75, by hand
  CHECK(has_row(r.out, {"catch_underarm", "catch_underarm", "1", "->", "9.8", "0.000", "->",
                        "0.250", "16", "0.500"}));
  CHECK(has_row(r.out, {"hand_over", "hand_over_free", "4", "->", "12", "-", "->", "-", "16",
                        "-"}));
  CHECK(has_row(r.out, {"catch_abreast", "catch_abreast", "5", "->", "33.4", "0.125", "->",
                        "0.500", "8", "0.750"}));
  CHECK(has_text(r.out, "mean normalised score after adaptation: 0.625 (2 of 3 tasks)"));
  CHECK(has_text(r.out, "evaluation 2  run 2 (maml, suite ML4)  split test  after 2 adaptation "
                        "episodes and 3 gradient steps"));
  // two_catch_underarm has a ground truth but no random score here
  CHECK(has_text(r.out, "mean normalised score after adaptation: - (no task has both "
                        "references)"));
  CHECK(has_text(r.out, "2 evaluations in"));
  r = reg_run("evals --run " + std::to_string(other), path);
  REQUIRE(r.rc == 0);
  CHECK_FALSE(has_text(r.out, "evaluation 1 "));
  CHECK(has_text(r.out, "evaluation 2 "));
  CHECK(has_text(r.out, "1 evaluation in"));
  r = reg_run("evals --run 99", path);
  CHECK(r.rc == 2);
  CHECK(has_text(r.out, "no run with id 99"));
  CHECK(reg_run("evals --run 0", path).rc == 2);

  // the age report of evaluation 1: its after-adaptation returns, to a chosen file
  const std::string out = dir.file("eval.svg");
  r = reg_run("report age --eval 1 --out " + q(out), path);
  REQUIRE(r.rc == 0);
  CHECK(has_text(r.out, "scores of evaluation 1 of run 1 (promp on ML4, split train, after 1 "
                        "adaptation episode and 1 gradient step)"));
  // task, age, difficulty, run, return, random, ground truth, normalised
  CHECK(has_row(r.out, {"catch_abreast", "9-10", "easy", "1", "33.4", "3.4", "43.4", "0.750"}));
  CHECK(has_row(r.out, {"catch_underarm", "48", "hard", "1", "9.8", "1.8", "17.8", "0.500"}));
  // hand_over_free, a registered variant: hand_over's age, its ground truth, no random score here
  CHECK(has_row(r.out, {"hand_over", "9-10", "easy", "1", "12", "-", "268.1", "-"}));
  check_order(r.out, {"catch_abreast", "hand_over", "catch_underarm"});
  CHECK(has_text(r.out, "left out of the plot (no normalised score): hand_over"));
  CHECK(has_text(r.out, "plot (2 of 3 tasks)"));
  REQUIRE(file_exists(out));
  const std::string svg = read_file(out);
  CHECK(has_text(svg, ">catch_abreast<"));
  CHECK(has_text(svg, ">catch_underarm<"));
  CHECK(has_text(svg, "evaluation 1 of run 1"));
  // bad choices: exit 2 with a message
  r = reg_run("report age --eval 5", path);
  CHECK(r.rc == 2);
  CHECK(has_text(r.out, "no evaluation with id 5"));
  r = reg_run("report age --eval 1 --run 1", path);
  CHECK(r.rc == 2);
  CHECK(has_text(r.out, "give one of --suite, --run and --eval, not several"));
  CHECK(reg_run("report age --eval 1 --suite ML4", path).rc == 2);
  r = reg_run("report age --eval 0", path);
  CHECK(r.rc == 2);
  CHECK(has_text(r.out, "--eval takes an evaluation id >= 1"));
}

TEST_CASE("every bidex registry command has --help naming --registry", "[registry][apps]") {
  for (const char* c :
       {"list", "add-task", "scores", "evals", "offline", "reference", "report age"}) {
    INFO(c);
    CommandResult r = bidex_run(std::string("registry ").append(c).append(" --help"));
    CHECK(r.rc == 0);
    CHECK(has_text(r.out, "--registry"));
  }
  CommandResult r = bidex_run("registry --help");
  CHECK(r.rc == 0);
  for (const char* c : {"list", "add-task", "scores", "evals", "offline", "reference", "report"})
    CHECK(has_text(r.out, c));
}

TEST_CASE("bidex registry offline: datasets with their references, their runs normalised",
          "[registry][apps][offline]") {
  RegTempDir dir;
  const std::string path = dir.file("reg.sqlite");
  {
    Registry reg(path);
    registry::DatasetRecord d;
    d.checksum = "sha256:" + std::string(64, 'e');
    d.dataset_id = "hand_over/medium-v0";
    d.task = "hand_over";
    d.quality = "medium";
    d.path = "/data/m";
    d.total_steps = 5000;
    d.total_episodes = 70;
    d.ref_min = 10.0;
    d.ref_max = 210.0;
    reg.put_dataset(d);
    registry::RunRecord run;
    run.algo = "td3bc";
    run.task = "hand_over";
    run.dataset = d.checksum;
    run.steps = 20000;
    const int64_t id = reg.begin_run(run);
    run.final_return = 60.0;  // (60 - 10) / (210 - 10) = 25
    run.status = "finished";
    reg.finish_run(id, run, {});
  }
  CommandResult r = reg_run("offline", path);
  CHECK(r.rc == 0);
  CHECK(has_text(r.out, "hand_over"));
  CHECK(has_text(r.out, "medium"));
  CHECK(has_text(r.out, "td3bc"));
  CHECK(has_text(r.out, "normalised 25.0"));
  CHECK(has_text(r.out, "1 dataset in"));
  r = reg_run("offline --task door_open_outward", path);
  CHECK(has_text(r.out, "0 datasets in"));
}

TEST_CASE("a registry file that is not SQLite: exit 2 naming it", "[registry][apps]") {
  RegTempDir dir;
  const std::string path = dir.file("text.sqlite");
  std::string junk;
  for (int i = 0; i < 100; ++i) junk.append("plain text, not a database\n");
  write_file_atomic(path, junk);
  CommandResult r = reg_run("list", path);
  CHECK(r.rc == 2);
  CHECK(has_text(r.out, path));
  CHECK(has_text(r.out, "not a bidex registry"));
  CHECK(read_file(path) == junk);
}
