// metarl on the learning core: maml, promp and rl2 registered as meta algorithms; their runs
// stop, resume and evaluate with the protocol (before and after adaptation, per task);
// adaptation moves each task's policy its own way; the refusals (a suite without a held-out
// test split, an unknown split, a non-meta run, bad settings); and, with the [learning] label,
// meta-training on a small goal distribution whose held-out goals gain from adaptation; and
// `bidex eval --split`'s normalised scores through the binary.
#include "tests/rl/rl_fixture.h"

#include <algorithm>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/files.h"
#include "metarl/algorithms.h"
#include "rl/algorithm.h"
#include "rl/checkpoint.h"
#include "taskpack/pack.h"
#include "taskpack/suite.h"

using namespace bidex;

namespace {

// ML1-raise-goals's layout (configs/suites), inline so that the tests can edit it
const char* kRaiseGoals = R"(id: raise-goals
description: catch_underarm_raise, goals in a 10 x 10 x 6 cm box; 8 train, 4 held-out test goals
mode: meta
source: bidex's CI meta-learning test
goal_seed: 7
train:
  - {task: catch_underarm_raise, label: train_goals, goals: {count: 8, half_extent: [0.05, 0.05, 0.03]}}
test:
  - {task: catch_underarm_raise, label: test_goals, goals: {count: 4, half_extent: [0.05, 0.05, 0.03]}}
)";

// A tiny meta configuration: 8 slots, networks of 16, one update of each algorithm's steps.
std::string tiny_meta(const std::string& algo, const std::string& suite,
                      std::vector<std::string> extra = {}) {
  metarl::register_algorithms();
  std::vector<std::string> o = {"env.slots=8", "env.threads=1", "train.save_interval=1",
                                "train.device=cpu", "train.torch_threads=1"};
  if (algo == "rl2") {
    o.insert(o.end(), {"rl2.hidden_size=16", "rl2.horizon=8", "rl2.minibatches=2",
                       "rl2.epochs=1", "train.steps=64"});
  } else {
    o.insert(o.end(), {algo + ".hidden=[16]", algo + ".horizon=4", algo + ".epochs=1",
                       algo + ".inner_lr=0.1", "train.steps=64"});
  }
  for (auto& e : extra) o.push_back(e);
  return rl::resolve_train_yaml(rl::default_train_config(algo), algo, suite, o);
}

// A step's transition with no episode cut by the time limit.
rl::Transition transition(const torch::Tensor& obs, const torch::Tensor& reward,
                          const torch::Tensor& done) {
  rl::Transition tr;
  tr.obs = obs;
  tr.reward = reward;
  tr.done = done;
  tr.final_ids = torch::empty({0}, torch::kLong);
  tr.final_obs = torch::empty({0, obs.size(1)});
  return tr;
}

}  // namespace

TEST_CASE("maml, promp and rl2 are meta algorithms of the registry, and registering twice is "
          "refused",
          "[metarl]") {
  metarl::register_algorithms();
  metarl::register_algorithms();  // a second call does nothing
  for (const char* a : {"maml", "promp", "rl2"}) {
    INFO(a);
    const auto info = rl::find_algorithm(a);
    CHECK(info.meta);
    CHECK(info.trains_on == rl::TrainsOn::kSuite);
    CHECK(info.section == a);
    CHECK(rl::section_reader(a) != nullptr);
  }
  CHECK_FALSE(rl::find_algorithm("ppo").meta);
  CHECK(rl::section_reader("ppo") == nullptr);
  CHECK_THROWS_AS(rl::register_algorithm(rl::find_algorithm("promp"), metarl::make_promp,
                                         [](const YamlView&) {}),
                  std::logic_error);
}

TEST_CASE("a meta pack's slots take one task per goal, in turn", "[metarl][taskpack]") {
  test::TaskTempDir tmp;
  const auto suite = taskpack::load_suite(tmp.write("raise-goals.yaml", kRaiseGoals));
  const auto spec = taskpack::suite_pack(suite, "train", 10);
  taskpack::PackOptions po;
  po.threads = 1;
  taskpack::TaskPack pack(spec, po);
  int ntasks = 0;
  const auto tasks = pack.slot_tasks(&ntasks);
  CHECK(ntasks == 8);
  CHECK(tasks == std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 0, 1});
  // without goals, each entry is one task
  const auto mt4 = taskpack::suite_pack(taskpack::load_suite("MT4"), "train", 8);
  int n4 = 0;
  std::vector<int> t4;
  {
    taskpack::TaskPack p4(mt4, po);
    t4 = p4.slot_tasks(&n4);
  }
  CHECK(n4 == 4);
  CHECK(t4 == std::vector<int>{0, 0, 1, 1, 2, 2, 3, 3});
}

TEST_CASE("meta runs stop, resume from their checkpoints and adapt at evaluation", "[metarl]") {
  test::TaskTempDir tmp;
  const std::string suite = tmp.write("raise-goals.yaml", kRaiseGoals);
  for (const char* algo : {"maml", "promp", "rl2"}) {
    INFO(algo);
    const std::string dir = tmp.file(std::string("run-") + algo);
    auto o = test::quiet();
    o.stop_after_updates = 1;
    const auto first = rl::train_new(tiny_meta(algo, suite, {"train.steps=128"}), dir, o);
    CHECK(first.interrupted);
    CHECK(first.updates == 1);
    const auto second = rl::train_resume(dir, test::quiet());
    CHECK_FALSE(second.interrupted);
    CHECK(second.updates == 2);
    CHECK(rl::read_checkpoint_meta(second.checkpoint).algo == algo);

    rl::LoadedPolicy policy(dir);
    REQUIRE(policy.adaptive() != nullptr);
    const auto r = rl::evaluate_meta(policy, "test", 2, 1, 1, 5, 1);
    REQUIRE(r.per_task.size() == 1);
    CHECK(r.per_task[0].label == "test_goals");
    CHECK(r.per_task[0].episodes == 2 * 4);  // 2 slots per held-out goal
    CHECK(r.adapt_steps == (std::string(algo) == "rl2" ? 0 : 1));  // RL^2 adapts in memory
    CHECK(std::isfinite(r.return_before));
    CHECK(std::isfinite(r.return_after));
    CHECK(r.faults == 0);
    // the same seed gives the same scores
    const auto again = rl::evaluate_meta(policy, "test", 2, 1, 1, 5, 1);
    CHECK(again.return_before == r.return_before);
    CHECK(again.return_after == r.return_after);
  }
}

TEST_CASE("bidex eval --split normalises each task before and after adaptation with the "
          "registry's references, and says when it cannot",
          "[metarl][cmd]") {
  test::TaskTempDir tmp;
  auto q = [](const std::string& s) { return "'" + s + "'"; };
  // trained on goals of catch_underarm_raise, which the registry does not know (so it has no
  // references); held out: goals of it and of catch_underarm, whose references the test sets
  const std::string suite = tmp.write("goals.yaml", R"(id: goals
description: catch_underarm_raise goals, and held-out goals of it and of catch_underarm
mode: meta
source: this test
goal_seed: 7
train:
  - {task: catch_underarm_raise, label: train, goals: {count: 4, half_extent: [.05, .05, .03]}}
test:
  - {task: catch_underarm, label: known, goals: {count: 2, half_extent: [.05, .05, .03]}}
  - {task: catch_underarm_raise, label: unknown, goals: {count: 2, half_extent: [.05, .05, .03]}}
)");
  const std::string reg = tmp.file("registry.sqlite"), run = tmp.file("promp");
  test::CommandResult r = test::bidex_run(
      "train --suite " + q(suite) + " --algo promp -o env.slots=8 -o env.threads=1 "
      "-o train.device=cpu -o train.torch_threads=1 -o 'promp.hidden=[16]' -o promp.horizon=4 "
      "-o promp.epochs=1 -o train.steps=64 --run " + q(run) + " --registry " + q(reg));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  for (const auto& [kind, value] : {std::pair{"random", "-2"}, std::pair{"ground_truth", "6"}}) {
    r = test::bidex_run("registry reference --registry " + q(reg) + " --task "
                        "catch_underarm --kind " + kind + " --value " + value +
                        " --source test");
    REQUIRE(r.rc == 0);
  }
  const std::string json = tmp.file("eval.json");
  r = test::bidex_run("eval --run " + q(run) + " --split test --episodes 2 --registry " + q(reg) +
                      " --json " + q(json));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK_THAT(r.out, Catch::Contains("normalised (random 0, ground truth 1): "));
  // its progress on stderr: 8 slots (2 entries x 2 goals x 2 episodes), each through the
  // episode before adaptation, one adaptation episode and the one after
  CHECK_THAT(r.out, Catch::Contains(" (test) [############################] 100% 24/24 episodes"));
  CHECK_THAT(r.out, Catch::Contains("the mean of 1 of 2 entries (the others' tasks lack a "
                                    "reference"));
  auto j = nlohmann::json::parse(read_file(json));
  REQUIRE(j["per_task"].size() == 2);
  CHECK(j["per_task"][1]["task"] == "catch_underarm_raise");
  CHECK(j["per_task"][1]["normalised_before"].is_null());
  CHECK(j["per_task"][1]["normalised_after"].is_null());
  const auto& e = j["per_task"][0];
  REQUIRE(e["task"] == "catch_underarm");
  // (return - random) / (ground truth - random)
  const double before = (e["return_before"].get<double>() + 2) / 8;
  const double after = (e["return_after"].get<double>() + 2) / 8;
  CHECK(e["normalised_before"].get<double>() == Approx(before).epsilon(1e-12));
  CHECK(e["normalised_after"].get<double>() == Approx(after).epsilon(1e-12));
  CHECK(j["normalised_before"].get<double>() == Approx(before).epsilon(1e-12));
  CHECK(j["normalised_after"].get<double>() == Approx(after).epsilon(1e-12));
  CHECK(j["normalised_entries"] == 1);
  CHECK(j["registry_evaluation"].get<int64_t>() > 0);

  // the train split's only task has no references; and no registry at all
  r = test::bidex_run("eval --run " + q(run) + " --split train --episodes 2 --registry " + q(reg));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK_THAT(r.out, Catch::Contains("normalised: none (no task here has both references in the "
                                    "registry"));
  r = test::bidex_run("eval --run " + q(run) + " --split test --episodes 2 --no-registry --json " +
                      q(json));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK_THAT(r.out, Catch::Contains("normalised: none (--no-registry)"));
  j = nlohmann::json::parse(read_file(json));
  CHECK(j["normalised_after"].is_null());
  CHECK(j["per_task"][0]["normalised_before"].is_null());
  CHECK(j["normalised_entries"] == 0);
}

TEST_CASE("MAML and ProMP adapt each task's policy from its own rows, and not without steps",
          "[metarl]") {
  metarl::register_algorithms();
  test::TaskTempDir tmp;
  const std::string suite = tmp.write("raise-goals.yaml", kRaiseGoals);
  for (const char* algo : {"maml", "promp"}) {
    INFO(algo);
    const auto c = rl::parse_train_config(tiny_meta(algo, suite), "tiny");
    const int64_t D = 8, A = 3, N = 4;
    auto alg = rl::make_algorithm(algo, c, D, A, 0, torch::Device(torch::kCPU));
    rl::Adaptive* ad = alg->adaptive();
    REQUIRE(ad != nullptr);
    // slots 0, 1 are task 0 (rewarded for a positive first action), slots 2, 3 task 1 (for a
    // negative one); every slot sees the same observation
    const auto obs = torch::ones({N, D});
    const std::vector<int> tasks = {0, 0, 1, 1};
    auto run = [&](int steps) {
      torch::manual_seed(3);
      ad->begin(tasks, 2);
      for (int t = 0; t < 16; ++t) {
        const auto a = ad->explore(obs);
        const auto sign = torch::tensor({1.f, 1.f, -1.f, -1.f});
        ad->observe(transition(obs, sign * a.select(1, 0),
                               torch::full({N}, t % 4 == 3 ? 1.f : 0.f)),
                    torch::ones({N}));
      }
      ad->adapt(steps);
      return ad->exploit(obs);
    };
    const auto before = alg->actor(obs);
    const auto unchanged = run(0);
    CHECK(torch::allclose(unchanged, before));
    const auto after = run(1);
    // task 0's first action rose and task 1's fell; slots of one task act alike
    CHECK(after[0][0].item<float>() > before[0][0].item<float>());
    CHECK(after[2][0].item<float>() < before[2][0].item<float>());
    CHECK(torch::allclose(after[0], after[1]));
    CHECK(torch::allclose(after[2], after[3]));
    // begin() starts again from the meta-policy
    ad->begin(tasks, 2);
    CHECK(torch::allclose(ad->exploit(obs), before));
  }
}

TEST_CASE("MAML's and ProMP's input_norm and task_reward_norm: scale-free inputs and rewards, "
          "kept by checkpoints",
          "[metarl]") {
  metarl::register_algorithms();
  test::TaskTempDir tmp;
  const std::string suite = tmp.write("raise-goals.yaml", kRaiseGoals);
  const int64_t D = 6, A = 2, N = 4;
  const torch::Device cpu(torch::kCPU);
  for (const char* algo : {"maml", "promp"}) {
    INFO(algo);
    const std::string a = algo;
    // the critic's initialisation draws from torch's global stream: seeded here, so that two
    // algorithms made alike start alike
    auto make = [&](bool input_norm, bool reward_norm, int64_t slots) {
      torch::manual_seed(1);
      const auto yaml = tiny_meta(algo, suite,
                                  {a + ".input_norm=" + (input_norm ? "true" : "false"),
                                   a + ".task_reward_norm=" + (reward_norm ? "true" : "false")});
      return rl::make_algorithm(algo, rl::parse_train_config(yaml, "tiny"), D, A, slots, cpu);
    };
    // Feeds `steps` steps of observations affine in `x` ([steps, N, D]); two tasks, rewarded
    // `scale0` and `scale1` times the first action; returns the first update's metrics.
    auto feed = [&](rl::Algorithm& alg, const torch::Tensor& x, double offset, double mult,
                    double scale0, double scale1) {
      alg.set_slot_tasks({0, 0, 1, 1}, 2);
      std::vector<double> metrics;
      const auto scale = torch::tensor({scale0, scale0, scale1, scale1}, torch::kFloat32);
      for (int64_t t = 0; t < x.size(0); ++t) {
        const auto obs = offset + mult * x[t];
        const auto act = alg.act(obs);
        alg.observe(transition(obs, scale * act.select(1, 0).clamp(-1, 1), torch::zeros({N})));
        if ((t + 1) % alg.steps_per_update() != 0) continue;
        const auto m = alg.update(obs);
        if (metrics.empty()) metrics = m;
      }
      return metrics;
    };
    torch::manual_seed(11);
    const auto x = torch::randn({16, N, D});
    const auto probe = torch::randn({N, D});

    // input_norm: observations 1000 x + 5 act as x does, once both have been seen
    auto plain = make(true, false, N);
    torch::manual_seed(2);
    feed(*plain, x, 0, 1, 1, 1);
    auto wide = make(true, false, N);
    torch::manual_seed(2);
    feed(*wide, x, 5, 1000, 1, 1);
    CHECK(torch::allclose(plain->actor(probe), wide->actor(5 + 1000 * probe), 1e-3, 1e-4));
    auto raw = make(false, false, N);
    CHECK_FALSE(torch::allclose(raw->actor(probe), raw->actor(5 + 1000 * probe), 1e-3, 1e-4));
    // the statistics are the checkpoint's
    const std::string ckpt = tmp.file(a + "-norm.ckpt");
    {
      torch::serialize::OutputArchive root;
      wide->save(root);
      root.save_to(ckpt);
    }
    auto loaded = make(true, false, 0);
    {
      torch::serialize::InputArchive root;
      root.load_from(ckpt);
      loaded->load_actor(root, ckpt);
    }
    CHECK(torch::allclose(loaded->actor(5 + 1000 * probe), wide->actor(5 + 1000 * probe)));

    // task_reward_norm: task 0 pays 1000 times the action, task 1 a thousandth of it; the
    // critic learns scaled returns, and the reported rewards stay the tasks' own
    auto scaled = make(false, true, N);
    torch::manual_seed(3);
    const auto with = feed(*scaled, x, 0, 1, 1000, 0.001);
    auto unscaled = make(false, false, N);
    torch::manual_seed(3);
    const auto without = feed(*unscaled, x, 0, 1, 1000, 0.001);
    const auto& names = scaled->metric_names();
    const auto at = [&](const std::string& n) {
      return std::find(names.begin(), names.end(), n) - names.begin();
    };
    INFO("value loss with " << with[at("value_loss")] << ", without " << without[at("value_loss")]);
    CHECK(with[at("value_loss")] < 100);
    CHECK(without[at("value_loss")] > 1000);
    CHECK(with[at("reward_pre")] == Approx(without[at("reward_pre")]).epsilon(1e-6));
    // its statistics too; a checkpoint without them is refused
    const std::string sckpt = tmp.file(a + "-scale.ckpt");
    {
      torch::serialize::OutputArchive root;
      scaled->save(root);
      root.save_to(sckpt);
    }
    auto resumed = make(false, true, N);
    resumed->set_slot_tasks({0, 0, 1, 1}, 2);  // as the trainer does before loading
    CHECK_NOTHROW([&] {
      torch::serialize::InputArchive root;
      root.load_from(sckpt);
      resumed->load(root, sckpt);
    }());
    const std::string uckpt = tmp.file(a + "-unscaled.ckpt");
    {
      torch::serialize::OutputArchive root;
      unscaled->save(root);
      root.save_to(uckpt);
    }
    CHECK_THROWS_WITH(
        [&] {
          torch::serialize::InputArchive root;
          root.load_from(uckpt);
          resumed->load(root, uckpt);
        }(),
        Catch::Contains(uckpt));

    // at evaluation a task's scale comes from its own adaptation rows: rewards a thousand times
    // larger adapt the policy exactly as much
    auto adapted = [&](bool reward_norm, float mult) {
      auto alg = make(false, reward_norm, 0);
      rl::Adaptive* ad = alg->adaptive();
      const auto obs = torch::ones({N, D});
      torch::manual_seed(5);
      ad->begin({0, 0, 1, 1}, 2);
      for (int t = 0; t < 16; ++t) {
        const auto act = ad->explore(obs);
        ad->observe(transition(obs, mult * torch::tensor({1.f, 1.f, -1.f, -1.f}) * act.select(1, 0),
                               torch::full({N}, t % 4 == 3 ? 1.f : 0.f)),
                    torch::ones({N}));
      }
      ad->adapt(1);
      return ad->exploit(obs);
    };
    CHECK(torch::allclose(adapted(true, 1), adapted(true, 1000), 1e-4, 1e-5));
    CHECK_FALSE(torch::allclose(adapted(false, 1), adapted(false, 1000), 1e-4, 1e-5));
  }
}

TEST_CASE("MAML's and ProMP's learn_inner_lr (Meta-SGD): step sizes per element that the outer "
          "loss moves, kept by checkpoints and used at evaluation",
          "[metarl]") {
  metarl::register_algorithms();
  test::TaskTempDir tmp;
  const std::string suite = tmp.write("raise-goals.yaml", kRaiseGoals);
  const int64_t D = 6, A = 2, N = 4;
  const torch::Device cpu(torch::kCPU);
  for (const char* algo : {"maml", "promp"}) {
    INFO(algo);
    const std::string a = algo;
    auto make = [&](bool learn, int64_t slots) {
      torch::manual_seed(1);
      const auto yaml =
          tiny_meta(algo, suite, {a + ".learn_inner_lr=" + (learn ? "true" : "false")});
      return rl::make_algorithm(algo, rl::parse_train_config(yaml, "tiny"), D, A, slots, cpu);
    };
    // one update on two tasks rewarded for opposite first actions
    auto train = [&](rl::Algorithm& alg) {
      alg.set_slot_tasks({0, 0, 1, 1}, 2);
      torch::manual_seed(2);
      const auto sign = torch::tensor({1.f, 1.f, -1.f, -1.f});
      std::vector<double> m;
      for (int t = 0; t < alg.steps_per_update(); ++t) {
        const auto obs = torch::randn({N, D});
        const auto act = alg.act(obs);
        alg.observe(transition(obs, sign * act.select(1, 0).clamp(-1, 1), torch::zeros({N})));
      }
      return alg.update(torch::randn({N, D}));
    };
    // an adaptation at evaluation from the same exploration rows
    auto adapted = [&](rl::Algorithm& alg) {
      rl::Adaptive* ad = alg.adaptive();
      const auto obs = torch::ones({N, D});
      torch::manual_seed(5);
      ad->begin({0, 0, 1, 1}, 2);
      for (int t = 0; t < 8; ++t) {
        const auto act = ad->explore(obs);
        ad->observe(transition(obs, torch::tensor({1.f, 1.f, -1.f, -1.f}) * act.select(1, 0),
                               torch::full({N}, t % 4 == 3 ? 1.f : 0.f)),
                    torch::ones({N}));
      }
      ad->adapt(1);
      return ad->exploit(obs);
    };
    auto learned = make(true, N);
    const auto& names = learned->metric_names();
    const auto at = [&](const std::string& n) {
      return std::find(names.begin(), names.end(), n) - names.begin();
    };
    REQUIRE(at("inner_lr_max") < static_cast<std::ptrdiff_t>(names.size()));
    const auto m = train(*learned);
    REQUIRE(m.size() == names.size());
    // the sizes started at inner_lr (0.1) and the outer step moved them both ways
    INFO("inner_lr min " << m[at("inner_lr_min")] << ", mean " << m[at("inner_lr_mean")]
                         << ", max " << m[at("inner_lr_max")]);
    CHECK(m[at("inner_lr_min")] < 0.1 * (1 - 1e-5));
    CHECK(m[at("inner_lr_max")] > 0.1 * (1 + 1e-5));
    CHECK(m[at("inner_lr_min")] > 0);
    // without learn_inner_lr there are no such metrics
    auto plain = make(false, N);
    CHECK(plain->metric_names().size() == names.size() - 3);
    CHECK(train(*plain).size() == names.size() - 3);

    // a checkpoint keeps them: a new algorithm that loads it adapts exactly as the trained one;
    // one that keeps inner_lr everywhere adapts otherwise
    const std::string ckpt = tmp.file(a + "-metasgd.ckpt");
    {
      torch::serialize::OutputArchive root;
      learned->save(root);
      root.save_to(ckpt);
    }
    auto loaded = make(true, 0);
    {
      torch::serialize::InputArchive root;
      root.load_from(ckpt);
      loaded->load_actor(root, ckpt);
    }
    const auto want = adapted(*learned);
    CHECK(torch::equal(adapted(*loaded), want));
    auto same_policy = make(false, 0);  // the meta-policy and critic, the plain step size
    {
      torch::serialize::InputArchive root;
      root.load_from(ckpt);
      same_policy->load_actor(root, ckpt);
    }
    CHECK(torch::equal(same_policy->actor(torch::ones({N, D})), learned->actor(torch::ones({N, D}))));
    CHECK_FALSE(torch::allclose(adapted(*same_policy), want, 1e-6, 1e-7));
    // a checkpoint without step sizes is refused by a run that learns them
    const std::string old = tmp.file(a + "-plain.ckpt");
    {
      torch::serialize::OutputArchive root;
      plain->save(root);
      root.save_to(old);
    }
    auto resumed = make(true, N);
    resumed->set_slot_tasks({0, 0, 1, 1}, 2);
    CHECK_THROWS_WITH(
        [&] {
          torch::serialize::InputArchive root;
          root.load_from(old);
          resumed->load(root, old);
        }(),
        Catch::Contains(old));
  }
}

TEST_CASE("meta-RL refuses suites without a held-out test split, unknown splits and non-meta "
          "runs, and bad settings name their key",
          "[metarl]") {
  metarl::register_algorithms();
  test::TaskTempDir tmp;
  // a multi-task suite
  {
    const std::string yaml = tiny_meta("promp", "MT4");
    try {
      rl::train_new(yaml, tmp.file("mt4"), test::quiet());
      FAIL("MT4 was accepted");
    } catch (const ConfigError& e) {
      CHECK(e.key() == "suite");
      CHECK_THAT(e.what(), Catch::Contains("no held-out test split"));
      CHECK_THAT(e.what(), Catch::Contains("MT4"));
    }
    CHECK_FALSE(test::file_exists(tmp.file("mt4/config.yaml")));
  }
  // a meta suite whose test split is its train split
  {
    std::string text = kRaiseGoals;
    text = text.substr(0, text.find("test:")) + "test: train\n";
    const std::string file = tmp.write("no-test.yaml", text);
    CHECK_THROWS_WITH(rl::train_new(tiny_meta("rl2", file), tmp.file("no-test"), test::quiet()),
                      Catch::Contains("its test split is its train split"));
  }
  const std::string suite = tmp.write("raise-goals.yaml", kRaiseGoals);
  // an unknown split
  {
    const std::string dir = tmp.file("maml");
    rl::train_new(tiny_meta("maml", suite), dir, test::quiet());
    rl::LoadedPolicy policy(dir);
    try {
      rl::evaluate_meta(policy, "validation", 2, 1, 1, 5, 1);
      FAIL("split 'validation' was accepted");
    } catch (const ConfigError& e) {
      CHECK(e.key() == "split");
      CHECK_THAT(e.what(), Catch::Contains("train or test"));
      CHECK_THAT(e.what(), Catch::Contains("validation"));
    }
  }
  // a run of an algorithm that does not adapt
  {
    const std::string dir = tmp.file("ppo");
    rl::train_new(test::tiny_yaml("catch_underarm_raise"), dir, test::quiet());
    rl::LoadedPolicy policy(dir);
    CHECK(policy.adaptive() == nullptr);
    CHECK_THROWS_WITH(rl::evaluate_meta(policy, "test", 2, 1, 1, 5, 1),
                      Catch::Contains("trained ppo, which does not adapt"));
  }
  // bad settings
  for (const auto& [override_, key] : std::vector<std::pair<std::string, std::string>>{
           {"promp.inner_steps=-1", "inner_steps"},
           {"promp.target_kl=0", "target_kl"},
           {"promp.activation=sigmoid", "activation"}}) {
    INFO(override_);
    try {
      tiny_meta("promp", suite, {override_});
      FAIL("accepted");
    } catch (const ConfigError& e) {
      CHECK_THAT(e.key(), Catch::Contains(key));
    }
  }
  CHECK_THROWS_WITH(tiny_meta("maml", suite, {"maml.target_kl=0.01"}),
                    Catch::Contains("target_kl"));  // ProMP's key only
  CHECK_THROWS_WITH(tiny_meta("rl2", suite, {"rl2.trial_episodes=0"}),
                    Catch::Contains("trial_episodes"));
}

// On ML1-raise-goals's held-out goals, with promp.yaml's per-suite defaults (92,160 slot-steps,
// about 30 s on two cores): after meta-training, one adaptation episode per slot and one step
// lift the return by 2.08-2.32 over seeds 0-3; after a single update (before meta-training has
// done anything) the same protocol lifts it by 0.30-1.48 (bench/results/
// learning-meta-promp-2core.json). The bar, 1.5, is above every gain without meta-training.
TEST_CASE("ProMP meta-learns ML1-raise-goals: adaptation lifts held-out goals' return",
          "[metarl][learning]") {
  metarl::register_algorithms();
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  const std::string yaml = rl::resolve_train_yaml(rl::default_train_config("promp"), "promp",
                                                  "ML1-raise-goals", {"seed=1"});
  const auto r = rl::train_new(yaml, dir, test::quiet());
  REQUIRE(r.steps >= 92160);
  rl::LoadedPolicy policy(dir);
  const auto e = rl::evaluate_meta(policy, "test", 16, 1, 1, 12345, 0);
  INFO("before " << e.return_before << ", after " << e.return_after);
  CHECK(e.faults == 0);
  CHECK(e.return_after > e.return_before + 1.5);
}
