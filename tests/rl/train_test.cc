// The training workflow on real tasks: the run folder, metrics, learning curve, checkpoints
// (atomic, verified), stopping and resuming, evaluation, and every bad input the issue names
// (unknown task or algorithm, malformed override, a checkpoint of another task, a truncated
// checkpoint), through the API and through the bidex binary.
#include <csignal>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

#include <unistd.h>

#include "tests/rl/rl_fixture.h"

#include "core/clock.h"
#include "core/error.h"
#include "registry/registry.h"
#include "rl/checkpoint.h"
#include "rl/metrics.h"
#include "rl/trainer.h"
#include "tasks/registry.h"
#include "sim/physics.h"

using namespace bidex;

namespace {

std::vector<double> metric(const std::string& dir, const std::string& col) {
  std::vector<std::string> cols;
  std::vector<std::vector<double>> rows;
  rl::parse_metrics_csv(read_file(dir + "/metrics.csv"), dir, cols, rows);
  size_t c = 0;
  while (c < cols.size() && cols[c] != col) ++c;
  REQUIRE(c < cols.size());
  std::vector<double> out;
  for (auto& r : rows) out.push_back(r[c]);
  return out;
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  FAIL("no bidex::Error");
  return "";
}
}  // namespace

TEST_CASE("a training run writes its config, metrics, curve and checkpoints", "[rl][train]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  const std::string yaml = test::tiny_yaml("hand_over", {"train.steps=96"});
  auto r = rl::train_new(yaml, dir, test::quiet());
  CHECK(r.updates == 3);
  CHECK(r.steps == 96);
  CHECK_FALSE(r.interrupted);
  // config.yaml is the resolved YAML with ppo.yaml's `auto` settings as this CPU learner decided
  // them (rl/config.h, settle_auto): the plain float32 networks
  const std::string config = read_file(dir + "/config.yaml");
  std::string want = yaml;
  for (const std::string key : {"bf16", "bf16_act", "align_widths"}) {
    const std::string was = "  " + key + ": auto\n";
    REQUIRE(want.find(was) != std::string::npos);
    want.replace(want.find(was), was.size(), "  " + key + ": false\n");
  }
  CHECK(config == want);
  CHECK(test::file_exists(dir + "/run.json"));
  CHECK(test::file_exists(dir + "/summary.json"));
  CHECK(metric(dir, "update") == std::vector<double>{1, 2, 3});
  CHECK(metric(dir, "steps") == std::vector<double>{32, 64, 96});
  for (double f : metric(dir, "fps")) CHECK(f > 0);
  for (double l : metric(dir, "lr")) CHECK(l > 0);
  // every reward term of the task has a column, and the JSONL has one object per update
  CHECK(metric(dir, "term_pose").size() == 3);
  const std::string jsonl = read_file(dir + "/metrics.jsonl");
  CHECK(std::count(jsonl.begin(), jsonl.end(), '\n') == 3);
  CHECK(jsonl.find("\"return\":null") != std::string::npos);  // no episode ends in 24 steps
  const std::string svg = read_file(dir + "/learning_curve.svg");
  CHECK(svg.rfind("<svg", 0) == 0);
  CHECK(svg.find("mean episode return") != std::string::npos);
  // save_interval 1, keep 3: the three newest, the last one the final update
  auto cks = rl::list_checkpoints(dir);
  REQUIRE(cks.size() == 3);
  const auto m = rl::read_checkpoint_meta(cks.back());
  CHECK(m.task == "hand_over");
  CHECK(m.update == 3);
  CHECK(m.steps == 96);
  CHECK(m.obs_dim == 398);
  CHECK(m.act_dim == 40);
  CHECK(m.config_hash == rl::config_hash(config));
  // the settled config builds the networks the checkpoint holds
  rl::LoadedPolicy policy(dir);
  CHECK(policy.act(torch::zeros({2, 398}), false).sizes() == torch::IntArrayRef({2, 40}));
}

TEST_CASE("a run steps the physics its env.physics names", "[rl][train]") {
  // the default physics named explicitly trains bitwise as the default; four substeps of
  // 1/240 s do not
  test::TaskTempDir tmp;
  const std::string coarse = tmp.file("physics-4.yaml");
  {
    std::ofstream out(coarse);
    out << "substeps: 4\n";
  }
  auto returns = [&](const std::string& name, const std::string& physics) {
    std::vector<std::string> o = {"train.steps=96"};
    if (!physics.empty()) o.push_back("env.physics=" + physics);
    rl::train_new(test::tiny_yaml("hand_over", o), tmp.file(name), test::quiet());
    return metric(tmp.file(name), "value_loss");  // observations and rewards differ
  };
  const auto base = returns("default", "");
  CHECK(returns("named", sim::default_physics_path()) == base);
  CHECK(returns("coarse", coarse) != base);
}

TEST_CASE("episode returns and success reach the metrics once episodes end", "[rl][train]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  // catch_underarm_raise: 40-step episodes, 8 steps per update: episodes end in update 5
  rl::train_new(test::tiny_yaml("catch_underarm_raise", {"train.steps=192"}), dir, test::quiet());
  const auto ret = metric(dir, "return"), eps = metric(dir, "episodes");
  REQUIRE(ret.size() == 6);
  CHECK(std::isnan(ret[0]));
  CHECK(eps[4] == 4);
  CHECK(std::isfinite(ret[4]));
  CHECK(ret[4] > 0);
  CHECK(metric(dir, "success")[4] >= 0);
  CHECK(metric(dir, "length")[4] == 40);
}

TEST_CASE("a stopped run resumes from its checkpoint and ends where an unbroken one does",
          "[rl][train]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  auto o = test::quiet();
  o.stop_after_updates = 2;
  auto r1 = rl::train_new(test::tiny_yaml("hand_over", {"train.steps=128"}), dir, o);
  CHECK(r1.interrupted);
  CHECK(r1.updates == 2);
  CHECK(rl::read_checkpoint_meta(rl::list_checkpoints(dir).back()).update == 2);
  // the physics' load of every update: constraint rows and solver iterations per slot-step
  for (const char* col : {"efc_rows", "solver_iters"})
    for (double v : metric(dir, col)) CHECK((std::isfinite(v) && v > 0));
  // the log as a bidex before those two columns wrote it, with a row written after the
  // checkpoint (as if the process died before the next one), which is kept aside
  std::vector<std::string> cols;
  std::vector<std::vector<double>> rows;
  rl::parse_metrics_csv(read_file(dir + "/metrics.csv"), dir, cols, rows);
  auto old_log = [&](const std::vector<std::string>& drop) {
    auto kept = [&](size_t c) { return std::find(drop.begin(), drop.end(), cols[c]) == drop.end(); };
    std::string text;
    for (size_t c = 0; c < cols.size(); ++c)
      if (kept(c)) text.append(text.empty() ? "" : ",").append(cols[c]);
    text += '\n';
    rows.push_back(rows.back());
    rows.back()[0] = 3;
    for (const auto& r : rows) {
      std::string line;
      for (size_t c = 0; c < cols.size(); ++c)
        if (kept(c)) line.append(line.empty() ? "" : ",").append(std::to_string(r[c]));
      text.append(line).append("\n");
    }
    rows.pop_back();
    return text;
  };
  // a column this run does not write: not this run's log, named
  {
    std::string text = old_log({});
    text.replace(text.find("sim_fps"), 7, "gpu_fps");
    write_file_atomic(dir + "/metrics.csv", text);
    CHECK(error_of([&] { rl::train_resume(dir, test::quiet()); })
              .find(dir + "/metrics.csv: its columns") != std::string::npos);
  }
  write_file_atomic(dir + "/metrics.csv", old_log({"efc_rows", "solver_iters"}));
  auto r2 = rl::train_resume(dir, test::quiet());
  CHECK_FALSE(r2.interrupted);
  CHECK(r2.updates == 4);
  CHECK(r2.steps == 128);
  CHECK(metric(dir, "update") == std::vector<double>{1, 2, 3, 4});
  CHECK(test::file_exists(dir + "/metrics.after_update_2.csv"));
  // the old rows have the new columns empty, the resumed session's are filled
  const std::vector<double> efc = metric(dir, "efc_rows");
  CHECK((std::isnan(efc[0]) && std::isnan(efc[1]) && efc[2] > 0 && efc[3] > 0));
  CHECK(metric(dir, "sim_fps")[1] == Approx(rows[1][4]));
  CHECK(rl::read_checkpoint_meta(rl::list_checkpoints(dir).back()).update == 4);
  // a finished run resumes to nothing new
  auto r3 = rl::train_resume(dir, test::quiet());
  CHECK(r3.updates == 4);
}

TEST_CASE("a wall-clock deadline stops a run after the update that passes it and its checkpoint "
          "resumes", "[rl][train][apps]") {
  test::TaskTempDir tmp;
  // a deadline already passed (as when setup outlasts --wall-limit): the first update runs, then
  // the run stops as Ctrl-C would
  auto o = test::quiet();
  o.stop_at_monotonic_s = monotonic_seconds() - 1;
  const std::string dir = tmp.file("passed");
  auto r1 = rl::train_new(test::tiny_yaml("hand_over", {"train.steps=128"}), dir, o);
  CHECK(r1.interrupted);
  CHECK(r1.updates == 1);
  CHECK(rl::read_checkpoint_meta(rl::list_checkpoints(dir).back()).update == 1);
  auto r2 = rl::train_resume(dir, test::quiet());
  CHECK_FALSE(r2.interrupted);
  CHECK(r2.updates == 4);
  // a deadline far ahead changes nothing
  o.stop_at_monotonic_s = monotonic_seconds() + 3600;
  auto r3 = rl::train_new(test::tiny_yaml("hand_over", {"train.steps=128"}), tmp.file("ahead"), o);
  CHECK_FALSE(r3.interrupted);
  CHECK(r3.updates == 4);
  // bidex train --wall-limit counts from the command's start, its setup included: 1 ms has
  // passed before the first update, which runs; exit 130 as for Ctrl-C
  const std::string args = "train --task catch_underarm_raise -o env.slots=4 -o env.threads=1 "
                           "-o train.steps=256 -o ppo.hidden=[16] -o train.device=cpu "
                           "--no-registry --run ";  // four updates of 64 slot-steps
  auto r = test::bidex_run(args + tmp.file("cli") + " --wall-limit 0.001");
  INFO(r.out);
  CHECK(r.rc == 130);
  CHECK(metric(tmp.file("cli"), "update") == std::vector<double>{1});
  CHECK(rl::read_checkpoint_meta(rl::list_checkpoints(tmp.file("cli")).back()).update == 1);
  r = test::bidex_run(args + tmp.file("zero") + " --wall-limit 0");
  CHECK(r.rc != 0);
  CHECK(r.out.find("--wall-limit") != std::string::npos);
  CHECK_FALSE(test::file_exists(tmp.file("zero")));
}

TEST_CASE("a training time limit stops a run after the update that passes it and the earlier of "
          "it and a wall-clock deadline counts", "[rl][train]") {
  test::TaskTempDir tmp;
  // --time-limit of a nanosecond: the first update runs, then the run stops as Ctrl-C would
  auto o = test::quiet();
  o.time_limit_s = 1e-9;
  auto r1 = rl::train_new(test::tiny_yaml("hand_over", {"train.steps=128"}), tmp.file("short"), o);
  CHECK(r1.interrupted);
  CHECK(r1.updates == 1);
  // an hour: the run ends on its own
  o.time_limit_s = 3600;
  auto r2 = rl::train_new(test::tiny_yaml("hand_over", {"train.steps=128"}), tmp.file("long"), o);
  CHECK_FALSE(r2.interrupted);
  CHECK(r2.updates == 4);
  // an hour's time limit with a passed wall-clock deadline: the deadline stops it
  o.stop_at_monotonic_s = monotonic_seconds() - 1;
  auto r3 = rl::train_new(test::tiny_yaml("hand_over", {"train.steps=128"}), tmp.file("both"), o);
  CHECK(r3.interrupted);
  CHECK(r3.updates == 1);
  // a far deadline with a nanosecond's time limit: the time limit stops it
  o.stop_at_monotonic_s = monotonic_seconds() + 3600;
  o.time_limit_s = 1e-9;
  auto r4 = rl::train_new(test::tiny_yaml("hand_over", {"train.steps=128"}), tmp.file("both2"), o);
  CHECK(r4.interrupted);
  CHECK(r4.updates == 1);
}

TEST_CASE("an existing run folder is never overwritten by a new run", "[rl][train]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  rl::train_new(test::tiny_yaml("hand_over"), dir, test::quiet());
  const std::string before = read_file(dir + "/metrics.csv");
  const std::string msg =
      error_of([&] { rl::train_new(test::tiny_yaml("hand_over"), dir, test::quiet()); });
  CHECK(msg.find("exists and is not empty") != std::string::npos);
  CHECK(msg.find("--resume") != std::string::npos);
  CHECK(read_file(dir + "/metrics.csv") == before);
}

TEST_CASE("truncated, corrupted and foreign checkpoints are clear errors", "[rl][train]") {
  test::TaskTempDir tmp;
  const std::string a = tmp.file("a"), b = tmp.file("b");
  rl::train_new(test::tiny_yaml("hand_over"), a, test::quiet());
  rl::train_new(test::tiny_yaml("catch_underarm_raise"), b, test::quiet());
  const std::string ck = rl::list_checkpoints(a).back();
  const std::string bytes = read_file(ck);

  SECTION("truncated") {
    write_file_atomic(ck, bytes.substr(0, bytes.size() - 100));
    const std::string msg = error_of([&] { rl::LoadedPolicy p(a); });
    CHECK(msg.find(ck) != std::string::npos);
    CHECK(msg.find("truncated") != std::string::npos);
    const std::string metrics = read_file(a + "/metrics.csv");
    CHECK(error_of([&] { rl::train_resume(a, test::quiet()); }).find("truncated") !=
          std::string::npos);
    CHECK(read_file(a + "/metrics.csv") == metrics);  // nothing rewritten
    CHECK(read_file(ck).size() == bytes.size() - 100);
  }
  SECTION("a flipped byte in the weights") {
    std::string bad = bytes;
    bad[bad.size() - 50] ^= 0x5a;
    write_file_atomic(ck, bad);
    CHECK(error_of([&] { rl::LoadedPolicy p(a); }).find("corrupted") != std::string::npos);
  }
  SECTION("not a checkpoint") {
    write_file_atomic(ck, "hello\n");
    CHECK(error_of([&] { rl::LoadedPolicy p(a); }).find("not a bidex checkpoint") !=
          std::string::npos);
  }
  SECTION("another task's checkpoint") {
    const std::string msg =
        error_of([&] { rl::LoadedPolicy p(b, rl::list_checkpoints(a).back()); });
    CHECK(msg.find("trained on task hand_over") != std::string::npos);
    CHECK(msg.find("is task catch_underarm_raise") != std::string::npos);
  }
  SECTION("another algorithm's checkpoint") {
    // the same task and shapes, its header naming another algorithm: refused before loading,
    // for evaluation and for resuming alike
    rl::CheckpointMeta m = rl::read_checkpoint_meta(ck);
    m.algo = "sac";
    torch::serialize::OutputArchive empty;
    rl::save_checkpoint(ck, m, empty);
    const std::string msg = error_of([&] { rl::LoadedPolicy p(a); });
    CHECK(msg.find(ck) != std::string::npos);
    CHECK(msg.find("holds the state of algorithm sac") != std::string::npos);
    CHECK(msg.find("trains with ppo") != std::string::npos);
    CHECK(error_of([&] { rl::train_resume(a, test::quiet()); }).find("algorithm sac") !=
          std::string::npos);
  }
  SECTION("a checkpoint whose networks differ from the run's config") {
    // same task, other hidden sizes
    const std::string c = tmp.file("c");
    rl::train_new(test::tiny_yaml("hand_over", {"ppo.hidden=[16]"}), c, test::quiet());
    const std::string msg = error_of([&] { rl::LoadedPolicy p(c, ck); });
    CHECK(msg.find("does not fit") != std::string::npos);
  }
}

namespace {
// `in` copied into `out` with every floating-point tensor, at any depth, filled with NaN.
void copy_as_nan(torch::serialize::InputArchive& in, torch::serialize::OutputArchive& out) {
  for (const std::string& key : in.keys()) {
    torch::Tensor t;
    torch::serialize::InputArchive sub;
    if (in.try_read(key, t)) {
      out.write(key, t.is_floating_point() ? torch::full_like(t, NAN) : t);
    } else if (in.try_read(key, sub)) {
      torch::serialize::OutputArchive o;
      copy_as_nan(sub, o);
      out.write(key, o);
    } else {
      c10::IValue v;
      REQUIRE(in.try_read(key, v));
      out.write(key, v);
    }
  }
}
}  // namespace

TEST_CASE("an update that leaves the learner non-finite stops the run without saving it",
          "[rl][train]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  auto o = test::quiet();
  o.stop_after_updates = 1;
  rl::train_new(test::tiny_yaml("hand_over", {"train.steps=128"}), dir, o);
  // the newest checkpoint's networks and optimiser state made NaN, as a diverged update leaves
  // them: the next update's losses are NaN
  const std::string ck = rl::list_checkpoints(dir).back();
  {
    torch::serialize::InputArchive in;
    const rl::CheckpointMeta m = rl::load_checkpoint(ck, in, torch::kCPU);
    torch::serialize::OutputArchive out;
    copy_as_nan(in, out);
    rl::save_checkpoint(ck, m, out);
  }
  const std::string bytes = read_file(ck), metrics = read_file(dir + "/metrics.csv");
  const std::string msg = error_of([&] { rl::train_resume(dir, test::quiet()); });
  CHECK(msg.find("train " + dir + ": update 2 diverged: its metric ") != std::string::npos);
  CHECK(msg.find(" is nan (expected a finite number)") != std::string::npos);
  CHECK(msg.find("the newest checkpoint, " + ck) != std::string::npos);
  CHECK(msg.find("bidex train --resume " + dir) != std::string::npos);
  // nothing of the diverged update is kept: no checkpoint, no metrics row
  CHECK(rl::list_checkpoints(dir) == std::vector<std::string>{ck});
  CHECK(read_file(ck) == bytes);
  CHECK(read_file(dir + "/metrics.csv") == metrics);
}

TEST_CASE("a PPO run writes each column of metrics.csv in its place with the metrics before the faults",
          "[rl][train]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  rl::train_new(test::tiny_yaml("hand_over", {"train.steps=128"}), dir, test::quiet());
  CHECK(metric(dir, "update") == std::vector<double>{1, 2, 3, 4});
  for (const char* col : {"policy_loss", "value_loss", "kl", "lr"})
    for (double v : metric(dir, col)) CHECK(std::isfinite(v));
  for (double v : metric(dir, "faults")) CHECK((v >= 0 && v == std::floor(v)));
  for (double v : metric(dir, "action_std")) CHECK(v == Approx(0.8).margin(0.05));
}

TEST_CASE("a loaded policy evaluates: returns, success and lengths of whole episodes",
          "[rl][train]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  rl::train_new(test::tiny_yaml("catch_underarm_raise"), dir, test::quiet());
  rl::LoadedPolicy p(dir);
  CHECK(p.update() == 2);
  auto r = rl::evaluate(p, 6, 9, 1);
  CHECK(r.episodes == 6);
  CHECK(r.mean_length == 40);  // nothing ends this task early at rest
  CHECK(r.mean_return > 0);
  CHECK(r.success_rate >= 0);
  CHECK(r.faults == 0);
  // deterministic: the same seed gives the same result
  auto r2 = rl::evaluate(p, 6, 9, 1);
  CHECK(r2.mean_return == r.mean_return);
  // under another YAML of its task (a curriculum run scored on the task itself): its values
  // rule, here a longer episode
  std::string yaml = read_file(tasks::default_task_config("catch_underarm_raise"));
  const std::string len = "episode_length: 40";
  REQUIRE(yaml.find(len) != std::string::npos);
  yaml.replace(yaml.find(len), len.size(), "episode_length: 55");
  const std::string other = tmp.write("long.yaml", yaml);
  auto r3 = rl::evaluate(p, 6, 9, 1, other);
  CHECK(r3.mean_length == 55);
  auto e = test::bidex_run("eval --run " + dir + " --task-config " + other +
                           " --episodes 2 --threads 1 --json " + tmp.file("long.json"));
  INFO(e.out);
  REQUIRE(e.rc == 0);
  CHECK(e.out.find("under " + other) != std::string::npos);
  CHECK(e.out.find("mean length 55.0") != std::string::npos);
  CHECK(read_file(tmp.file("long.json")).find("\"task_config\": \"" + other) != std::string::npos);
  // a YAML that is not the task's is a clear error that names the file
  e = test::bidex_run("eval --run " + dir + " --task-config " +
                      tasks::default_task_config("hand_over") + " --episodes 2 --threads 1");
  CHECK(e.rc == 2);
  CHECK(e.out.find("hand_over.yaml") != std::string::npos);
}

TEST_CASE("a run under re_orientation's curriculum logs the slots' mean level", "[rl][train]") {
  test::TaskTempDir tmp;
  const std::string yaml =
      tmp.write("curriculum.yaml", "extends: " + tasks::default_task_config("re_orientation") +
                                       "\ncurriculum: {enabled: true, start: 0.4, up: 0.02, "
                                       "down: 0.05}\n");
  const std::string dir = tmp.file("run");
  rl::train_new(test::tiny_yaml("re_orientation", {"env.task_config=" + yaml}), dir, test::quiet());
  const auto levels = metric(dir, "curriculum_level");
  REQUIRE(levels.size() == 2);
  for (double v : levels) {
    CHECK(v >= 0);
    CHECK(v <= 1);
    // the mean of the four slots' levels: 0.4 moved by steps of 0.02 / 4 and 0.05 / 4
    const double steps = (v - 0.4) / 0.0025;
    CHECK(std::abs(steps - std::round(steps)) < 1e-6);
  }
  // a resumed run's slots go on from the level logged last, not from the start: four-step
  // episodes lower every level by 0.05 a reset, 2 resets a slot an update
  const std::string quick =
      tmp.write("quick.yaml", "extends: " + tasks::default_task_config("re_orientation") +
                                  "\nepisode_length: 4\ncurriculum: {enabled: true, start: 1, "
                                  "up: 0.02, down: 0.05}\n");
  auto once = [&](const std::string& run, int stop) {
    auto o = test::quiet();
    o.stop_after_updates = stop;
    return rl::train_new(test::tiny_yaml("re_orientation", {"env.task_config=" + quick}), run, o);
  };
  const std::string whole = tmp.file("whole"), parts = tmp.file("parts");
  once(whole, 0);
  once(parts, 1);
  rl::train_resume(parts, test::quiet());
  const auto a = metric(whole, "curriculum_level"), b = metric(parts, "curriculum_level");
  REQUIRE(a.size() == 2);
  REQUIRE(b.size() == 2);
  CHECK(a[0] == b[0]);
  CHECK(a[1] < a[0]);
  CHECK(b[1] < b[0] - 0.05);  // from the logged level: from the start it would be about b[0]
  // without the curriculum, no such column
  const std::string plain = tmp.file("plain");
  rl::train_new(test::tiny_yaml("re_orientation"), plain, test::quiet());
  CHECK(read_file(plain + "/metrics.csv").find("curriculum_level") == std::string::npos);
}

TEST_CASE("the registry stores no score of a run played under another YAML of its task than its own",
          "[rl][train][apps]") {
  test::TaskTempDir tmp;
  // a training aid: the task's YAML with shorter episodes (as re_orientation's progress term)
  const std::string aid = tmp.write("aid.yaml", "extends: " +
                                                    tasks::default_task_config("catch_underarm_raise") +
                                                    "\nepisode_length: 20\n");
  const std::string dir = tmp.file("run"), db = tmp.file("reg.sqlite"), reg = " --registry " + db;
  auto t = test::bidex_run("train --task catch_underarm_raise -o env.slots=4 -o env.threads=1 "
                           "-o train.steps=128 -o ppo.hidden=[16] -o train.device=cpu "
                           "-o env.task_config=" + aid + " --run " + dir + reg);
  INFO(t.out);
  REQUIRE(t.rc == 0);
  CHECK(t.out.find("normalised n/a: trained under " + aid) != std::string::npos);
  {
    registry::Registry r(db);
    const auto run = r.run_by_dir(dir);
    REQUIRE(run);
    CHECK(run->status == "finished");
    CHECK(run->steps == 128);
    CHECK(r.scores(run->id).empty());
    CHECK_FALSE(run->final_return);
  }
  // its mean action under the aid is not stored; under the task's own YAML it is
  auto e = test::bidex_run("eval --run " + dir + " --episodes 2 --threads 1" + reg);
  INFO(e.out);
  REQUIRE(e.rc == 0);
  CHECK(e.out.find("mean length 20.0") != std::string::npos);
  CHECK(e.out.find("not stored (played under " + aid) != std::string::npos);
  CHECK(test::bidex_run("registry evals" + reg).out.find("1 evaluation in") == std::string::npos);
  e = test::bidex_run("eval --run " + dir + " --episodes 2 --threads 1 --task-config " +
                      tasks::default_task_config("catch_underarm_raise") + reg);
  INFO(e.out);
  REQUIRE(e.rc == 0);
  CHECK(e.out.find("mean length 40.0") != std::string::npos);
  CHECK(e.out.find(": evaluation 1 of run 1 (") != std::string::npos);
  CHECK(test::bidex_run("registry evals" + reg).out.find("1 evaluation in") != std::string::npos);
}

TEST_CASE("bidex train, eval and render --run work from the command line", "[rl][train][apps]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run"), reg = " --registry " + tmp.file("reg.sqlite");
  auto t = test::bidex_run("train --task hand_over -o env.slots=4 -o env.threads=1 "
                           "-o train.steps=64 -o ppo.hidden=[16] -o ppo.minibatches=2 "
                           "-o train.device=cpu --run " + dir + reg);
  INFO(t.out);
  REQUIRE(t.rc == 0);
  CHECK(t.out.find("2 updates, 64 slot-steps") != std::string::npos);
  auto e = test::bidex_run("eval --run " + dir + " --episodes 3 --threads 1 --json " +
                           tmp.file("eval.json") + reg);
  INFO(e.out);
  REQUIRE(e.rc == 0);
  CHECK(e.out.find("3 episodes, mean return") != std::string::npos);
  const std::string json = read_file(tmp.file("eval.json"));
  CHECK(json.find("\"success_rate\"") != std::string::npos);
  // the mean action's scores go to the run's record in the registry, as an evaluation without
  // adaptation that `registry evals` lists and `registry report age --eval` draws
  CHECK(e.out.find(": evaluation 1 of run 1 (") != std::string::npos);
  CHECK(json.find("\"registry_evaluation\": 1") != std::string::npos);
  auto ev = test::bidex_run("registry evals" + reg);
  INFO(ev.out);
  CHECK(ev.out.find("run 1 (ppo, hand_over)  split train  the mean action, no adaptation") !=
        std::string::npos);
  CHECK(ev.out.find("1 evaluation in") != std::string::npos);
  // --no-registry, and a play under another YAML of the task, store nothing
  e = test::bidex_run("eval --run " + dir + " --episodes 2 --threads 1 --no-registry" + reg);
  INFO(e.out);
  REQUIRE(e.rc == 0);
  CHECK(e.out.find(": evaluation ") == std::string::npos);
  // the task's own YAML named with --task-config is the task itself: stored
  e = test::bidex_run("eval --run " + dir + " --episodes 2 --threads 1 --task-config " +
                      tasks::default_task_config("hand_over") + reg);
  INFO(e.out);
  REQUIRE(e.rc == 0);
  CHECK(e.out.find(": evaluation 2 of run 1 (") != std::string::npos);
  CHECK(test::bidex_run("registry evals" + reg).out.find("2 evaluations in") != std::string::npos);
  auto h = test::bidex_run("train --help");
  CHECK(h.out.find("--resume") != std::string::npos);
  CHECK(h.out.find("-o,--override") != std::string::npos);
}

TEST_CASE("bidex train and eval reject bad input with exit 2 and a clear message",
          "[rl][train][apps]") {
  test::TaskTempDir tmp;
  auto r = test::bidex_run("train --task juggle");
  CHECK(r.rc == 2);
  CHECK(r.out.find("'juggle'") != std::string::npos);
  CHECK(r.out.find("hand_over") != std::string::npos);
  r = test::bidex_run("train --task hand_over --algo dqn");
  CHECK(r.rc == 2);
  CHECK(r.out.find("'dqn'") != std::string::npos);
  r = test::bidex_run("train --task hand_over -o ppo.lr");
  CHECK(r.rc == 2);
  CHECK(r.out.find("key.path=value") != std::string::npos);
  r = test::bidex_run("train --task hand_over -o ppo.lrate=1 --run " + tmp.file("x"));
  CHECK(r.rc == 2);
  CHECK(r.out.find("ppo.lrate") != std::string::npos);
  CHECK_FALSE(test::file_exists(tmp.file("x")));  // nothing written for a bad override
  r = test::bidex_run("eval --run " + tmp.file("nothing"));
  CHECK(r.rc == 2);
  CHECK(r.out.find(tmp.file("nothing")) != std::string::npos);
}

TEST_CASE("SIGINT during training writes a checkpoint that --resume continues", "[rl][train][apps]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  const std::string args = "train --task hand_over -o env.slots=4 -o env.threads=1 "
                           "-o train.steps=100000 -o ppo.hidden=[16] -o ppo.minibatches=2 "
                           "-o train.device=cpu -o train.save_interval=1000 --run " + dir;
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    std::string cmd = "exec '";
    cmd.append(BIDEX_BINARY).append("' ").append(args).append(" > /dev/null 2>&1");
    ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // wait until a few updates are logged, then interrupt
  for (int i = 0; i < 600; ++i) {
    if (test::file_exists(dir + "/metrics.csv") && metric(dir, "update").size() >= 3) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ::kill(pid, SIGINT);
  int status = 0;
  ::waitpid(pid, &status, 0);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 130);
  auto cks = rl::list_checkpoints(dir);
  REQUIRE(cks.size() == 1);  // save_interval 1000: only the one written on the signal
  const int64_t at = rl::read_checkpoint_meta(cks.back()).update;
  CHECK(at >= 3);
  CHECK(metric(dir, "update").back() == at);
  auto r = test::bidex_run("train --resume " + dir + " --stop-after " + std::to_string(at + 2));
  INFO(r.out);
  CHECK(r.rc == 130);
  CHECK(rl::read_checkpoint_meta(rl::list_checkpoints(dir).back()).update == at + 2);
}

TEST_CASE("bidex starts with idle threads that sleep, unless the user chose, and run.json says so",
          "[rl][train][apps]") {
  test::TaskTempDir tmp;
  const std::string args = "train --task catch_underarm_raise -o env.slots=4 -o train.steps=64 "
                           "-o ppo.hidden=[16] -o train.device=cpu --no-registry --run ";
  auto idle_threads = [&](const std::string& env, const std::string& dir) {
    std::string cmd = "env -u OMP_WAIT_POLICY -u OPENBLAS_THREAD_TIMEOUT " + env + " '";
    cmd.append(BIDEX_BINARY).append("' ").append(args).append(dir);
    auto r = test::run_command(cmd);
    INFO(r.out);
    REQUIRE(r.rc == 0);
    return nlohmann::json::parse(read_file(dir + "/run.json"))["sessions"][0]["idle_threads"];
  };
  // core/idle_threads.h: started again with the settings before any library read them
  auto unset = idle_threads("", tmp.file("unset"));
  CHECK(unset["OMP_WAIT_POLICY"] == "passive");
  CHECK(unset["OPENBLAS_THREAD_TIMEOUT"] == "4");
  auto chosen = idle_threads("OMP_WAIT_POLICY=active", tmp.file("chosen"));
  CHECK(chosen["OMP_WAIT_POLICY"] == "active");
  CHECK(chosen["OPENBLAS_THREAD_TIMEOUT"] == "4");
}

TEST_CASE("bidex render --run writes the frames of one episode of the trained policy",
          "[rl][train][apps]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run"), frames = tmp.file("frames");
  rl::train_new(test::tiny_yaml("catch_underarm_raise"), dir, test::quiet());
  auto r = test::bidex_run("render --run " + dir + " --out " + frames +
                           " --max-frames 3 --width 64 --height 48");
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK(r.out.find("wrote 3 frames") != std::string::npos);
  for (const char* f : {"/frame_00000.png", "/frame_00001.png", "/frame_00002.png"})
    CHECK(test::file_exists(frames + f));
  CHECK_FALSE(test::file_exists(frames + "/frame_00003.png"));
  // an MP4 when ffmpeg is installed, a note when it is not
  CHECK((r.out.find("episode.mp4") != std::string::npos ||
         r.out.find("ffmpeg is not on PATH") != std::string::npos));
  auto both = test::bidex_run("render --run " + dir + " --task hand_over --out " + frames);
  CHECK(both.rc == 2);
  CHECK(both.out.find("exactly one of --task") != std::string::npos);
}

TEST_CASE("bidex render --run of a suite run draws the chosen entry with the run's rows",
          "[rl][train][apps]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run"), frames = tmp.file("frames");
  rl::train_new(test::tiny_onpolicy_yaml("mtppo", "MT4", {"env.slots=8"}), dir, test::quiet());
  auto r = test::bidex_run("render --run " + dir + " --entry two_catch_underarm --out " + frames +
                           " --max-frames 2 --width 64 --height 48");
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK(r.out.find("wrote 2 frames to " + frames + " (two_catch_underarm") != std::string::npos);
  CHECK(test::file_exists(frames + "/frame_00001.png"));
  // an unknown entry names the suite's; --entry on a task run is refused
  auto bad = test::bidex_run("render --run " + dir + " --entry nope --out " + frames);
  CHECK(bad.rc == 2);
  CHECK(bad.out.find("catch_underarm, hand_over, catch_abreast, two_catch_underarm") !=
        std::string::npos);
  const std::string task_dir = tmp.file("task");
  rl::train_new(test::tiny_yaml("catch_underarm_raise"), task_dir, test::quiet());
  auto on_task = test::bidex_run("render --run " + task_dir + " --entry x --out " + frames);
  CHECK(on_task.rc == 2);
  CHECK(on_task.out.find("go with a suite run") != std::string::npos);
}

TEST_CASE("value normalisation trains, is saved and loads with the checkpoint", "[rl][train]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  rl::train_new(test::tiny_yaml("catch_underarm_raise", {"ppo.value_norm=true"}), dir,
                test::quiet());
  for (double v : metric(dir, "value_loss")) CHECK(std::isfinite(v));
  rl::LoadedPolicy p(dir);  // the value normaliser's buffers fit
  CHECK(rl::evaluate(p, 2, 1, 1).episodes == 2);
  // a checkpoint trained with it still fits a run without it (same tensors, unused)
  const std::string other = tmp.file("other");
  rl::train_new(test::tiny_yaml("catch_underarm_raise"), other, test::quiet());
  rl::LoadedPolicy q(other, rl::list_checkpoints(dir).back());
  CHECK(q.update() == 2);
}
