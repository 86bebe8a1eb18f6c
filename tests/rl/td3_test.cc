// rl/td3: TD3's target policy smoothing, clipped double-Q target and delayed actor against
// hand-worked values; a bandit's optimum learned; TD3 and DDPG runs that stop, resume from their
// checkpoints and evaluate; a checkpoint of one loaded as the other is refused; bad settings
// name their key.
#include "tests/rl/rl_fixture.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "rl/algorithm.h"
#include "rl/checkpoint.h"
#include "rl/td3.h"
#include "rl/trainer.h"

using namespace bidex;

namespace {

std::string tiny(const std::string& algo, std::vector<std::string> extra = {}) {
  std::vector<std::string> o = {
      "env.slots=4",           "env.threads=1",         "train.steps=64",
      algo + ".hidden=[32]",   algo + ".horizon=8",     algo + ".epochs=2",
      algo + ".minibatches=2", algo + ".batch_size=16", algo + ".replay_size=64",
      "train.save_interval=1", "train.device=cpu",      "train.torch_threads=1"};
  for (auto& e : extra) o.push_back(e);
  return rl::resolve_train_yaml(rl::default_train_config(algo), algo, "catch_underarm_raise", o);
}

}  // namespace

TEST_CASE("TD3's smoothed target action and clipped double-Q target match hand-worked values",
          "[rl][td3]") {
  // mu' = (0.9, -0.2), noise (1, -3) x std 0.2 = (0.2, -0.6), clipped to 0.5: (0.2, -0.5);
  // mu' + that = (1.1, -0.7), clamped to the action range: (1, -0.7)
  const auto a = rl::td3_target_action(torch::tensor({0.9, -0.2}, torch::kFloat64),
                                       torch::tensor({1.0, -3.0}, torch::kFloat64), 0.2, 0.5);
  CHECK(a[0].item<double>() == Approx(1.0));
  CHECK(a[1].item<double>() == Approx(-0.7));
  // without smoothing (DDPG) the target action is the target actor's
  const auto d = rl::td3_target_action(torch::tensor({0.3}, torch::kFloat64),
                                       torch::tensor({2.0}, torch::kFloat64), 0.0, 0.0);
  CHECK(d[0].item<double>() == Approx(0.3));
  // r + gamma (1 - terminal) min(q1', q2'): 1 + 0.5 x 3 = 2.5; a terminal row keeps its 2
  const auto y = rl::td3_q_target(torch::tensor({1.0, 2.0}), torch::tensor({0.0, 1.0}),
                                  torch::tensor({3.0, 5.0}), torch::tensor({4.0, 1.0}), 0.5);
  CHECK(y[0].item<float>() == Approx(2.5));
  CHECK(y[1].item<float>() == Approx(2.0));
  // the actor and the targets move on every second critic step, counted over the run
  std::vector<int> moved;
  for (int s = 0; s < 6; ++s) moved.push_back(rl::td3_actor_step(s, 2));
  CHECK(moved == std::vector<int>{0, 1, 0, 1, 0, 1});
  for (int s = 0; s < 3; ++s) CHECK(rl::td3_actor_step(s, 1));
}

TEST_CASE("TD3's actor loss adds the pre-tanh penalty to -Q as hand-worked", "[rl][td3]") {
  // q = (1, 3): -mean q = -2; preact = ((1, -2), (0, 3)): mean square (1 + 4 + 0 + 9) / 4 = 3.5
  const auto q = torch::tensor({1.0, 3.0}, torch::kFloat64);
  const auto pre = torch::tensor({1.0, -2.0, 0.0, 3.0}, torch::kFloat64).view({2, 2});
  CHECK(rl::td3_actor_loss(q, pre, 0.0).item<double>() == Approx(-2.0));
  CHECK(rl::td3_actor_loss(q, pre, 0.5).item<double>() == Approx(-2.0 + 0.5 * 3.5));
  // its gradient pulls each pre-activation towards 0 by 2 x 0.5 x preact / 4
  auto p = pre.clone().set_requires_grad(true);
  rl::td3_actor_loss(q, p, 0.5).backward();
  CHECK(torch::allclose(p.grad(), pre * 0.25));
}

TEST_CASE("TD3 delays its actor, and DDPG moves it every critic step", "[rl][td3]") {
  for (const char* algo : {"td3", "ddpg"}) {
    INFO(algo);
    const rl::TrainConfig c = rl::parse_train_config(tiny(algo), "tiny");
    auto alg = rl::make_algorithm(algo, c, 5, 2, 4, torch::Device(torch::kCPU));
    // one step of 4 slots, stored, then one update of 2 x 2 gradient steps
    auto obs = torch::randn({4, 5});
    auto act = alg->act(obs);
    CHECK(act.abs().max().item<float>() <= 1.f);
    rl::Transition t;
    t.obs = torch::randn({4, 5});
    t.reward = torch::ones({4});
    t.done = torch::zeros({4});
    t.final_ids = torch::empty({0}, torch::kLong);
    t.final_obs = torch::empty({0, 5});
    alg->observe(t);
    const auto before = alg->actor(obs);
    const auto m = alg->update(t.obs);
    const auto& names = alg->metric_names();
    const auto at = std::find(names.begin(), names.end(), "actor_steps") - names.begin();
    REQUIRE(at < static_cast<long>(names.size()));
    CHECK(m[at] == (std::string(algo) == "td3" ? 2.0 : 4.0));
    CHECK_FALSE(alg->actor(obs).equal(before));  // the actor learned
    // the delay's phase goes on over updates: 4 more steps, 2 more actor steps for TD3
    CHECK(alg->update(t.obs)[at] == (std::string(algo) == "td3" ? 2.0 : 4.0));
  }
}

TEST_CASE("TD3 and DDPG runs stop, resume from their checkpoints and evaluate", "[rl][td3]") {
  for (const char* algo : {"td3", "ddpg"}) {
    INFO(algo);
    test::TaskTempDir tmp;
    const std::string dir = tmp.file(algo);
    auto opt = test::quiet();
    opt.stop_after_updates = 1;
    auto r = rl::train_new(tiny(algo), dir, opt);
    CHECK(r.updates == 1);
    CHECK(rl::read_checkpoint_meta(rl::list_checkpoints(dir).back()).algo == algo);
    r = rl::train_resume(dir, test::quiet());
    CHECK(r.updates == 2);
    const std::string csv = read_file(dir + "/metrics.csv");
    for (const char* col : {"q_loss", "actor_loss", "q_mean", "actor_steps"})
      CHECK(csv.find(col) != std::string::npos);
    rl::LoadedPolicy p(dir);
    const auto e = rl::evaluate(p, 4, 3, 1);
    CHECK(e.episodes == 4);
    CHECK(std::isfinite(e.mean_return));
    CHECK(p.config().td3.preact_l2 == 1.0);  // catch_underarm_raise's per-task default
    // a run written before preact_l2 existed still loads, with the plain actor loss
    std::string cfg = read_file(dir + "/config.yaml");
    const size_t at = cfg.find("  preact_l2:");
    REQUIRE(at != std::string::npos);
    cfg.erase(at, cfg.find('\n', at) + 1 - at);
    write_file_atomic(dir + "/config.yaml", cfg);
    rl::LoadedPolicy old(dir);
    CHECK(old.config().td3.preact_l2 == 0.0);
  }
}

TEST_CASE("a TD3 checkpoint is refused by a DDPG run, and bad TD3 settings name their key",
          "[rl][td3]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("td3");
  rl::train_new(tiny("td3"), dir, test::quiet());
  // the run's config says ddpg from here on: its resume must refuse the TD3 state
  const std::string ddpg = tiny("ddpg");
  write_file_atomic(dir + "/config.yaml", ddpg);
  try {
    rl::train_resume(dir, test::quiet());
    FAIL("a TD3 checkpoint loaded into DDPG");
  } catch (const Error& e) {
    CHECK_THAT(e.what(), Catch::Contains("holds the state of algorithm td3") &&
                             Catch::Contains("trains with ddpg"));
  }
  for (auto [key, value, expected] :
       {std::tuple{"td3.policy_delay", "0", "an integer >= 1"},
        std::tuple{"td3.noise_clip", "-1", "a number in [0, 10]"},
        std::tuple{"td3.replay_size", "2", "at least env.slots"}}) {
    INFO(key);
    try {
      tiny("td3", {std::string(key) + "=" + value});
      FAIL("accepted");
    } catch (const ConfigError& err) {
      CHECK(err.key() == key);
      CHECK_THAT(err.what(), Catch::Contains(expected));
    }
  }
  // DDPG has no smoothing or delay: those keys are unknown there
  CHECK_THROWS_AS(tiny("ddpg", {"ddpg.policy_delay=2"}), ConfigError);
}

// Their actor and critic updates together find a known optimum: on a one-step bandit with
// reward -|a - target|^2 the actor converges to the target (within 0.1 after 500 updates of 16
// gradient steps; about 3 s each on two cores), without the pre-tanh penalty, which would pull
// it towards 0.
TEST_CASE("TD3 and DDPG learn a one-step bandit's best action", "[rl][td3]") {
  for (const char* algo : {"td3", "ddpg"}) {
    INFO(algo);
    torch::manual_seed(11);
    const std::string a = algo;
    const rl::TrainConfig c = rl::parse_train_config(
        tiny(algo, {a + ".replay_size=4096", a + ".batch_size=64", a + ".lr=1e-3",
                    a + ".epochs=4", a + ".minibatches=4", a + ".preact_l2=0", "env.slots=32"}),
        "tiny");
    auto alg = rl::make_algorithm(algo, c, 3, 2, 32, torch::Device(torch::kCPU));
    const auto obs = torch::zeros({32, 3});
    // reward -(|a - target|^2), every step its own episode (terminal)
    const auto target = torch::tensor({0.5f, -0.3f});
    rl::Transition t;
    t.obs = obs;
    t.done = torch::ones({32});
    t.final_ids = torch::empty({0}, torch::kLong);
    t.final_obs = torch::empty({0, 3});
    for (int u = 0; u < 500; ++u) {
      for (int s = 0; s < 2; ++s) {
        const auto act = alg->act(obs);
        t.reward = -(act - target).pow(2).sum(1);
        alg->observe(t);
      }
      alg->update(obs);
    }
    const auto best = alg->actor(obs.slice(0, 0, 1))[0];
    INFO("actor " << best);
    CHECK((best - target).abs().max().item<float>() < 0.1f);
  }
}
