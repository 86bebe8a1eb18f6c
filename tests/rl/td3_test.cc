// rl/td3: TD3's target policy smoothing, clipped double-Q target and delayed actor against
// hand-worked values; a bandit's optimum learned; TD3 and DDPG runs that stop, resume from their
// checkpoints and evaluate; a checkpoint of one loaded as the other is refused; bad settings
// name their key; their updates with FlatAdam against the same updates with LibTorch's Adam.
#include "tests/rl/mirror_fixture.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "rl/algorithm.h"
#include "rl/checkpoint.h"
#include "rl/policy.h"
#include "rl/replay.h"
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
        std::tuple{"td3.replay_size", "2", "at least env.slots"},
        std::tuple{"td3.cuda_graph", "sometimes", "true or false"}}) {
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
  // the update as a CUDA graph: on by default in both shipped sections (it learns as the eager
  // update on a GPU: bench/results/offpolicy-graph-h200x2), and a setting of both
  CHECK(rl::parse_train_config(tiny("td3"), "x.yaml").td3.cuda_graph);
  CHECK(rl::parse_train_config(tiny("ddpg"), "x.yaml").td3.cuda_graph);
  CHECK_FALSE(rl::parse_train_config(tiny("ddpg", {"ddpg.cuda_graph=false"}), "x.yaml").td3.cuda_graph);
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

namespace {

// rl/td3.cc's actor (its module "net" of A outputs, squashed by tanh).
struct MirrorTd3Actor : torch::nn::Module {
  MirrorTd3Actor(int64_t D, int64_t A, const rl::Td3Config& c) {
    net = register_module("net", rl::mlp(D, c.hidden, A, c.activation, 0.01));
  }
  torch::Tensor forward(const torch::Tensor& obs) { return torch::tanh(net->forward(obs)); }
  torch::nn::Sequential net{nullptr};
};

// TD3's and DDPG's update (rl/td3.cc) as it was with LibTorch's Adam and clip_grad_norm_, on
// copies of the learner's networks and step count read from its checkpoint state.
struct Td3Mirror {
  Td3Mirror(const rl::Td3Config& config, int64_t D, int64_t A,
            torch::serialize::InputArchive& root)
      : c(config),
        actor(std::make_shared<MirrorTd3Actor>(D, A, config)),
        actor_target(std::make_shared<MirrorTd3Actor>(D, A, config)),
        critic(D, A, config.hidden, config.activation, config.twin),
        critic_target(D, A, config.hidden, config.activation, config.twin) {
    test::load_part(root, "actor", *actor);
    test::load_part(root, "actor_target", *actor_target);
    test::load_part(root, "critic", *critic);
    test::load_part(root, "critic_target", *critic_target);
    torch::Tensor s;
    root.read("gradient_steps", s);
    step = s.item<int64_t>();
    actor_opt = std::make_unique<torch::optim::Adam>(actor->parameters(),
                                                     torch::optim::AdamOptions(c.lr));
    critic_opt = std::make_unique<torch::optim::Adam>(critic->parameters(),
                                                      torch::optim::AdamOptions(c.lr));
  }

  // q_loss, actor_loss (per actor step), q_mean, actor_steps: Td3Algorithm::update's first four
  std::vector<double> update(const rl::ReplayBuffer& replay) {
    double q_loss_sum = 0, actor_loss_sum = 0, q_sum = 0;
    int actor_steps = 0;
    const int n = c.epochs * c.minibatches;
    for (int k = 0; k < n; ++k, ++step) {
      const auto b = replay.sample(c.batch_size);
      torch::Tensor y;
      {
        torch::NoGradGuard ng;
        auto mu = actor_target->forward(b.next_obs);
        auto a_next = rl::td3_target_action(mu, torch::randn_like(mu), c.target_noise,
                                            c.noise_clip);
        auto [q1n, q2n] = critic_target->forward(b.next_obs, a_next);
        y = rl::td3_q_target(b.rewards, b.terminal, q1n, q2n, c.gamma);
      }
      auto [q1, q2] = critic->forward(b.obs, b.actions);
      auto q_loss = (q1 - y).pow(2).mean();
      if (c.twin) q_loss = 0.5 * (q_loss + (q2 - y).pow(2).mean());
      critic_opt->zero_grad();
      q_loss.backward();
      critic_norms.push_back(
          torch::nn::utils::clip_grad_norm_(critic->parameters(), c.max_grad_norm));
      critic_opt->step();
      if (rl::td3_actor_step(step, c.policy_delay)) {
        auto pre = actor->net->forward(b.obs);
        auto actor_loss =
            rl::td3_actor_loss(critic->forward(b.obs, torch::tanh(pre)).first, pre, c.preact_l2);
        actor_opt->zero_grad();
        actor_loss.backward();
        actor_norms.push_back(
          torch::nn::utils::clip_grad_norm_(actor->parameters(), c.max_grad_norm));
        actor_opt->step();
        rl::polyak_update(*actor, *actor_target, c.polyak);
        rl::polyak_update(*critic, *critic_target, c.polyak);
        actor_loss_sum += actor_loss.item<double>();
        ++actor_steps;
      }
      q_loss_sum += q_loss.item<double>();
      q_sum += q1.mean().item<double>();
    }
    return {q_loss_sum / n, actor_steps ? actor_loss_sum / actor_steps : 0.0, q_sum / n,
            static_cast<double>(actor_steps)};
  }

  rl::Td3Config c;
  std::shared_ptr<MirrorTd3Actor> actor, actor_target;
  rl::QCritic critic, critic_target;
  int64_t step = 0;
  std::unique_ptr<torch::optim::Adam> actor_opt, critic_opt;
  std::vector<double> critic_norms, actor_norms;  // the clips' norms
};

}  // namespace

TEST_CASE("TD3's and DDPG's FlatAdam updates step as LibTorch's Adam with clip_grad_norm_ did",
          "[rl][td3][ddpg][flat_adam]") {
  for (const std::string algo : {"td3", "ddpg"}) {
    INFO(algo);
    // a rate that moves the weights well beyond the tolerance, a clip that binds on every
    // critic step and some actor steps, and catch_underarm_raise's pre-tanh penalty
    const rl::TrainConfig c = rl::parse_train_config(
        tiny(algo, {algo + ".epochs=1", algo + ".minibatches=4", algo + ".lr=1e-3",
                    algo + ".max_grad_norm=0.16"}),
        "tiny");
    REQUIRE(c.td3.preact_l2 > 0);
    const int64_t N = 8, D = 5, A = 3;
    torch::manual_seed(3);
    auto alg = rl::make_algorithm(algo, c, D, A, N, torch::Device(torch::kCPU));
    // three steps of every slot into the learner's replay buffer and an identical one
    rl::ReplayBuffer replay(c.td3.replay_size, D, A, torch::Device(torch::kCPU));
    auto obs = torch::randn({N, D});
    for (int t = 0; t < 3; ++t) {
      const auto a = alg->act(obs);
      rl::Transition tr;
      tr.obs = torch::randn({N, D});
      tr.reward = torch::randn({N});
      // slot 1's episode ends by itself (terminal), slot 2's at its time limit (bootstrapped)
      tr.done = torch::zeros({N});
      tr.done.narrow(0, 1, 2).fill_(1);
      tr.final_ids = torch::tensor({int64_t(2)});
      tr.final_obs = torch::randn({1, D});
      alg->observe(tr);
      replay.add(obs, a, tr, c.td3.reward_scale);
      obs = tr.obs;
    }
    auto start = test::saved_state(*alg);
    Td3Mirror mirror(c.td3, D, A, start);
    const auto actor0 = test::param_copies(*mirror.actor);
    const auto critic0 = test::param_copies(*mirror.critic);
    // two updates of four gradient steps (TD3: two actor steps each), each from the same seed
    for (int u = 0; u < 2; ++u) {
      torch::manual_seed(100 + u);
      const auto got = alg->update(obs);
      torch::manual_seed(100 + u);
      const auto want = mirror.update(replay);
      for (size_t i = 0; i < want.size(); ++i) {
        INFO("update " << u << ", " << alg->metric_names()[i]);
        CHECK(got[i] == Approx(want[i]).epsilon(1e-4).margin(1e-5));
      }
    }
    test::check_clips(mirror.critic_norms, mirror.actor_norms, c.td3.max_grad_norm);
    auto after = test::saved_state(*alg);
    MirrorTd3Actor actor(D, A, c.td3), actor_target(D, A, c.td3);
    rl::QCritic critic(D, A, c.td3.hidden, c.td3.activation, c.td3.twin),
        critic_target(D, A, c.td3.hidden, c.td3.activation, c.td3.twin);
    test::load_part(after, "actor", actor);
    test::load_part(after, "actor_target", actor_target);
    test::load_part(after, "critic", *critic);
    test::load_part(after, "critic_target", *critic_target);
    CHECK(test::max_param_diff(actor, *mirror.actor) < test::kMirrorTol);
    CHECK(test::max_param_diff(actor_target, *mirror.actor_target) < test::kMirrorTol);
    CHECK(test::max_param_diff(*critic, *mirror.critic) < test::kMirrorTol);
    CHECK(test::max_param_diff(*critic_target, *mirror.critic_target) < test::kMirrorTol);
    CHECK(test::max_diff(actor0, actor.parameters()) > 100 * test::kMirrorTol);
    CHECK(test::max_diff(critic0, critic->parameters()) > 100 * test::kMirrorTol);
  }
}
