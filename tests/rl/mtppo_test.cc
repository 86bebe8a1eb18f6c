// Multi-task PPO on a suite (bidex train --suite MT4 --algo mtppo) and the registry record of
// every training run, through the API and the bidex binary: per-task metric columns, the one-hot
// widened observation reaching the networks, evaluation per task, resume, and the bad inputs.
#include "tests/rl/rl_fixture.h"

#include <cmath>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "registry/registry.h"
#include "rl/checkpoint.h"
#include "rl/metrics.h"
#include "rl/recent_scores.h"
#include "rl/trainer.h"
#include "taskpack/pack.h"
#include "taskpack/suite.h"

using namespace bidex;

namespace {

// A tiny multi-task run on a suite: 2 slots per task, small networks.
std::string tiny_suite_yaml(const std::string& suite, std::vector<std::string> extra = {}) {
  std::vector<std::string> o = {"env.slots=8", "ppo.epochs=1"};
  for (auto& e : extra) o.push_back(e);
  return test::tiny_onpolicy_yaml("mtppo", suite, o);
}

std::vector<std::string> header(const std::string& dir) {
  std::vector<std::string> cols;
  std::vector<std::vector<double>> rows;
  rl::parse_metrics_csv(read_file(dir + "/metrics.csv"), dir, cols, rows);
  return cols;
}
}  // namespace

TEST_CASE("mtppo trains on a suite's pack with per-task metrics and a one-hot observation",
          "[rl][mtppo]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("mt4");
  const std::string yaml = tiny_suite_yaml("MT4", {"train.steps=640"});  // 10 updates of 64
  CHECK(yaml.find("suite: MT4") != std::string::npos);
  CHECK(yaml.find("task:") == std::string::npos);  // a suite run names no task
  auto r = rl::train_new(yaml, dir, test::quiet());
  CHECK(r.updates == 10);
  // the pack of MT4: four tasks, two slots each, observations padded to the widest (446, two
  // objects) plus a 4-wide one-hot
  taskpack::PackSpec ps = taskpack::suite_pack(taskpack::load_suite("MT4"), "train", 8);
  REQUIRE(ps.entries.size() == 4);
  const auto m = rl::read_checkpoint_meta(rl::list_checkpoints(dir).back());
  CHECK(m.task == "MT4");
  CHECK(m.obs_dim == 446 + 4);
  CHECK(m.act_dim == 52);
  CHECK(m.task_version.rfind("MT4/train[", 0) == 0);
  // one return and one success column per task, plus the scaled mean
  const auto cols = header(dir);
  for (auto& e : ps.entries) {
    const std::string label = e.label.empty() ? e.task : e.label;
    CHECK(std::count(cols.begin(), cols.end(), "return_" + label) == 1);
    CHECK(std::count(cols.begin(), cols.end(), "success_" + label) == 1);
  }
  CHECK(std::count(cols.begin(), cols.end(), "scaled_return") == 1);
  CHECK(std::count(cols.begin(), cols.end(), "term_pose") == 0);  // terms differ between tasks
  // 80 steps per slot: every catch task (75 steps, or an earlier drop) ended episodes
  REQUIRE(r.scores.size() == 4);
  for (auto& s : r.scores) {
    CHECK(s.episodes >= 2);
    CHECK(std::isfinite(s.mean_return));
  }
  CHECK(read_file(dir + "/learning_curve.svg").find("per task") != std::string::npos);

  // evaluation runs each task of the suite with the policy's mean action
  rl::LoadedPolicy policy(dir);
  auto ev = rl::evaluate(policy, 2, 7, 1);
  REQUIRE(ev.per_task.size() == 4);
  CHECK(ev.episodes == 8);
  double mean = 0;
  for (auto& e : ev.per_task) mean += e.mean_return / 4;
  CHECK(ev.mean_return == Approx(mean));

  // resume continues the suite run
  auto r2 = rl::train_resume(dir, test::quiet());
  CHECK(r2.updates == 10);  // already at its configured steps: nothing more to do
}

TEST_CASE("mtppo's config is strict about suites and tasks", "[rl][mtppo]") {
  // a task algorithm gets no suite, a suite algorithm no task and no task_config
  CHECK_THROWS_AS(rl::parse_train_config("algo: mtppo\ntask: hand_over\n", "x.yaml"), ConfigError);
  CHECK_THROWS_AS(rl::parse_train_config("algo: ppo\nsuite: MT4\n", "x.yaml"), ConfigError);
  CHECK_THROWS_AS(tiny_suite_yaml("MT4", {"env.task_config=foo.yaml"}), ConfigError);
  CHECK_THROWS_AS(taskpack::load_suite("MT5"), ConfigError);
}

TEST_CASE("mtppo normalises advantages within each task when asked", "[rl][mtppo]") {
  // the same run (same seed, same first rollout) with batch and with task normalisation: the
  // first update's losses differ, and the run folder keeps the setting for a resume
  test::TaskTempDir tmp;
  std::vector<double> first_loss;
  for (std::string norm : {"batch", "task"}) {
    const std::string dir = tmp.file("mt4-" + norm);
    const std::string yaml =
        tiny_suite_yaml("MT4", {"train.steps=128", "ppo.advantage_norm=" + norm});
    auto r = rl::train_new(yaml, dir, test::quiet());
    CHECK(r.updates == 2);
    CHECK(read_file(dir + "/config.yaml").find("advantage_norm: " + norm) != std::string::npos);
    std::vector<std::string> cols;
    std::vector<std::vector<double>> rows;
    rl::parse_metrics_csv(read_file(dir + "/metrics.csv"), dir, cols, rows);
    const auto at = std::find(cols.begin(), cols.end(), "policy_loss") - cols.begin();
    REQUIRE(at < static_cast<long>(cols.size()));
    REQUIRE(rows.size() == 2);
    CHECK(std::isfinite(rows[0][at]));
    first_loss.push_back(rows[0][at]);
  }
  CHECK(first_loss[0] != first_loss[1]);
}

TEST_CASE("mtppo normalises the returns within each task when asked", "[rl][mtppo]") {
  // value_norm: task keeps one running mean and variance per task of the pack (ppo_test checks
  // them against each task's returns): the run trains, keeps the setting, and is not the run
  // with one normaliser
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("mt4-value-task");
  auto r = rl::train_new(tiny_suite_yaml("MT4", {"train.steps=128", "ppo.value_norm=task"}), dir,
                         test::quiet());
  CHECK(r.updates == 2);
  CHECK(read_file(dir + "/config.yaml").find("value_norm: task") != std::string::npos);
  CHECK(rl::parse_train_config(read_file(dir + "/config.yaml"), dir).ppo.value_norm_task);
  // and the same run with one normaliser is another run
  const std::string one = tmp.file("mt4-value-one");
  rl::train_new(tiny_suite_yaml("MT4", {"train.steps=128", "ppo.value_norm=true"}), one,
                test::quiet());
  std::vector<std::string> ca, cb;
  std::vector<std::vector<double>> ra, rb;
  rl::parse_metrics_csv(read_file(dir + "/metrics.csv"), dir, ca, ra);
  rl::parse_metrics_csv(read_file(one + "/metrics.csv"), one, cb, rb);
  const auto at = std::find(ca.begin(), ca.end(), "value_loss") - ca.begin();
  REQUIRE(at < static_cast<long>(ca.size()));
  REQUIRE(ra.size() == 2);
  REQUIRE(rb.size() == 2);
  CHECK(std::isfinite(ra[0][at]));
  CHECK(ra[0][at] != rb[0][at]);
}

TEST_CASE("bidex train records task and suite runs in the registry", "[rl][mtppo][registry]") {
  test::TaskTempDir tmp;
  const std::string reg = tmp.file("reg.sqlite");
  const std::string common = " -o env.threads=1 -o ppo.hidden=[32] -o ppo.minibatches=2 "
                             "-o ppo.epochs=1 -o train.device=cpu -o train.torch_threads=1 "
                             "--registry " + reg;
  auto a = test::bidex_run("train --task hand_over -o env.slots=4 -o train.steps=320 --run " +
                           tmp.file("task") + common);
  INFO(a.out);
  REQUIRE(a.rc == 0);
  CHECK(a.out.find("registry " + reg + ": run 1") != std::string::npos);
  auto b = test::bidex_run("train --suite MT1 -o env.slots=8 -o train.steps=640 --run " +
                           tmp.file("suite") + common);
  INFO(b.out);
  REQUIRE(b.rc == 0);
  for (const char* label : {"original", "left", "right", "back"})
    CHECK(b.out.find(label) != std::string::npos);  // the per-task table

  registry::Registry r(reg);
  auto runs = r.runs();
  REQUIRE(runs.size() == 2);
  const auto& t = runs[0].task == "hand_over" ? runs[0] : runs[1];
  const auto& s = runs[0].task == "hand_over" ? runs[1] : runs[0];
  CHECK(t.algo == "ppo");
  CHECK(t.suite.empty());
  CHECK(t.status == "finished");
  CHECK(t.steps == 320);
  CHECK_FALSE(t.code_version.empty());
  CHECK(t.config_hash.size() == 16);
  CHECK_FALSE(t.finished.empty());
  CHECK(s.algo == "mtppo");
  CHECK(s.suite == "MT1");
  CHECK(s.task.empty());
  CHECK(s.steps == 640);
  auto scores = r.scores(s.id);
  REQUIRE(scores.size() == 4);  // one per goal variant, all of catch_underarm
  for (auto& sc : scores) CHECK(sc.task == "catch_underarm");

  // a stopped run is recorded as stopped; --resume updates the same row
  auto c = test::bidex_run("train --task hand_over -o env.slots=4 -o train.steps=320 "
                           "--stop-after 2 --run " + tmp.file("staged") + common);
  CHECK(c.rc == 130);
  int64_t staged = 0;
  for (auto& run : r.runs())
    if (run.run_dir.find("staged") != std::string::npos) {
      staged = run.id;
      CHECK(run.status == "stopped");
      CHECK(run.steps == 64);
    }
  REQUIRE(staged > 0);
  auto d = test::bidex_run("train --resume " + tmp.file("staged") + " --registry " + reg);
  INFO(d.out);
  CHECK(d.rc == 0);
  CHECK(r.runs().size() == 3);
  for (auto& run : r.runs())
    if (run.id == staged) {
      CHECK(run.status == "finished");
      CHECK(run.steps == 320);
    }
}

TEST_CASE("bidex train and eval reject suite mistakes with clear messages", "[rl][mtppo]") {
  test::TaskTempDir tmp;
  auto both = test::bidex_run("train --task hand_over --suite MT4 --run " + tmp.file("x"));
  CHECK(both.rc == 2);
  CHECK(both.out.find("one of --task") != std::string::npos);
  auto meta = test::bidex_run("train --suite ML4 --run " + tmp.file("x"));
  CHECK(meta.rc == 2);
  CHECK(meta.out.find("meta-learning suite") != std::string::npos);
  auto ppo = test::bidex_run("train --suite MT4 --algo ppo --run " + tmp.file("x"));
  CHECK(ppo.rc == 2);
  CHECK(ppo.out.find("--algo mtppo") != std::string::npos);
  auto unknown = test::bidex_run("train --suite MT7 --run " + tmp.file("x"));
  CHECK(unknown.rc == 2);
  CHECK(unknown.out.find("MT20") != std::string::npos);  // lists the known suites
  CHECK_FALSE(test::file_exists(tmp.file("x")));

  // a random policy's score, per task of a suite, stored as the reference of the task
  const std::string reg = tmp.file("reg.sqlite");
  auto rnd = test::bidex_run("eval --random --task hand_over --episodes 3 --threads 1 "
                             "--set-reference --registry " + reg);
  INFO(rnd.out);
  REQUIRE(rnd.rc == 0);
  registry::Registry r(reg);
  bool found = false;
  for (auto& ref : r.references())
    if (ref.task == "hand_over" && ref.kind == "random") {
      found = true;
      CHECK(ref.source.find("3 episodes") != std::string::npos);
    }
  CHECK(found);
  auto rs = test::bidex_run("eval --random --suite MT4 --episodes 2 --threads 1");
  INFO(rs.out);
  CHECK(rs.rc == 0);
  CHECK(rs.out.find("two_catch_underarm") != std::string::npos);
  // its progress on stderr (not a terminal here): a line at the end with every episode counted
  CHECK(rs.out.find("eval MT4 [") != std::string::npos);
  CHECK(rs.out.find("100% 8/8 episodes") != std::string::npos);
}

TEST_CASE("bidex eval --zero plays the zero action as a baseline beside --random", "[rl][mtppo]") {
  test::TaskTempDir tmp;
  // door_close_outward: a random policy ends its episodes early (the task ends when a hand
  // strays 3 m from its handle), the zero action never does
  auto score = [&](const std::string& flag, int seed) {
    const std::string json = tmp.file(flag + std::to_string(seed) + ".json");
    auto r = test::bidex_run("eval " + flag + " --task door_close_outward --episodes 2 "
                             "--threads 1 --seed " + std::to_string(seed) + " --json " + json);
    INFO(r.out);
    REQUIRE(r.rc == 0);
    return nlohmann::json::parse(read_file(json));
  };
  const auto zero = score("--zero", 1);
  CHECK(zero["policy"] == "zero");
  CHECK(zero["mean_length"].get<double>() == 250.0);  // every episode runs to the time limit
  CHECK(std::isfinite(zero["mean_return"].get<double>()));
  // the task resets without noise, so the zero action plays the same episode for any seed ...
  CHECK(score("--zero", 2)["mean_return"].get<double>() == zero["mean_return"].get<double>());
  // ... and a random policy's are others
  const auto rnd = score("--random", 1);
  CHECK(rnd["policy"] == "random");
  CHECK(rnd["mean_length"].get<double>() < 250.0);
  CHECK(rnd["mean_return"].get<double>() != zero["mean_return"].get<double>());

  // per task of a suite's split
  auto suite = test::bidex_run("eval --zero --suite ML4 --split train --episodes 1 --threads 1");
  INFO(suite.out);
  CHECK(suite.rc == 0);
  CHECK(suite.out.find("ML4, zero action: 3 episodes") != std::string::npos);
  CHECK(suite.out.find("catch_abreast") != std::string::npos);

  // what --zero does not take
  auto both = test::bidex_run("eval --zero --random --task hand_over");
  CHECK(both.rc != 0);
  CHECK(both.out.find("excludes") != std::string::npos);
  auto ref = test::bidex_run("eval --zero --task hand_over --set-reference --registry " +
                             tmp.file("reg.sqlite"));
  CHECK(ref.rc == 2);
  CHECK(ref.out.find("the zero action is not one") != std::string::npos);
  CHECK_FALSE(test::file_exists(tmp.file("reg.sqlite")));
  auto run = test::bidex_run("eval --zero --run " + tmp.file("x"));
  CHECK(run.rc == 2);
  CHECK(run.out.find("not a run") != std::string::npos);
}

TEST_CASE("mttrpo trains TRPO on a suite's pack and evaluates per task", "[rl][mtppo][trpo]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("mt4-trpo");
  const std::string yaml = test::tiny_onpolicy_yaml(
      "mttrpo", "MT4", {"env.slots=8", "trpo.epochs=1", "train.steps=128"});
  CHECK(yaml.find("suite: MT4") != std::string::npos);
  auto r = rl::train_new(yaml, dir, test::quiet());
  CHECK(r.updates == 2);
  const auto m = rl::read_checkpoint_meta(rl::list_checkpoints(dir).back());
  CHECK(m.algo == "mttrpo");
  CHECK(m.obs_dim == 446 + 4);
  // a return column per task, the scaled mean, and TRPO's own metrics
  const auto cols = header(dir);
  CHECK(std::count_if(cols.begin(), cols.end(),
                      [](const std::string& c) { return c.rfind("return_", 0) == 0; }) == 4);
  for (const char* c : {"scaled_return", "step_fraction", "kl"})
    CHECK(std::count(cols.begin(), cols.end(), c) == 1);
  rl::LoadedPolicy p(dir);
  const auto e = rl::evaluate(p, 2, 4, 1);
  CHECK(e.per_task.size() == 4);
}

TEST_CASE("a run's final score per entry counts its last updates in which episodes ended, "
          "so that an entry whose episodes end together far apart keeps a score") {
  rl::RecentScores recent(2);
  auto stats = [](int64_t episodes, double return_sum, int64_t successes) {
    tasks::EpisodeStats e;
    e.episodes = episodes;
    e.return_sum = return_sum;
    e.successes = successes;
    return e;
  };
  // entry 0 ends episodes every update; entry 1 only in the first update of five
  recent.add({stats(2, 2.0, 0), stats(4, 40.0, 2)});
  for (int k = 0; k < 4; ++k) recent.add({stats(1, 10.0 * (k + 1), 1), {}});
  const auto a = recent.score(0, "a", "catch_underarm");
  CHECK(a.label == "a");
  CHECK(a.task == "catch_underarm");
  CHECK(a.episodes == 2);                  // the last two updates only: 30 and 40
  CHECK(a.mean_return == Approx(35.0));
  CHECK(a.success == Approx(1.0));
  const auto b = recent.score(1, "b", "switch");
  CHECK(b.episodes == 4);                  // kept although four updates without episodes came after
  CHECK(b.mean_return == Approx(10.0));
  CHECK(b.success == Approx(0.5));
  // an entry that never ended an episode has no score
  rl::RecentScores none(3);
  none.add({{}, stats(1, 1.0, 0)});
  const auto c = none.score(0, "c", "hand_over");
  CHECK(c.episodes == 0);
  CHECK(std::isnan(c.mean_return));
  CHECK(std::isnan(c.success));
}
