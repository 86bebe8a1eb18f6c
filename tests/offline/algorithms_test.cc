// offline: the losses of BC, BCQ, TD3+BC and IQL against hand-worked values; their registration
// and strict sections; the dataset checks of set_data; checkpoints that restore training and
// acting; and small learning checks on synthetic data (BC fits a linear policy; TD3+BC, IQL and
// BCQ find a bandit's best action among mixed good and random ones).
#include "tests/rl/rl_fixture.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <tuple>

#include "core/error.h"
#include "offline/algorithms.h"
#include "offline/losses.h"

using namespace bidex;

namespace {

const char* kDataset = "/data/synthetic/bandit-v0";

// The algorithm's defaults on the CPU, with `extra` overrides (no dataset read).
rl::TrainConfig config(const std::string& algo, std::vector<std::string> extra = {}) {
  offline::register_algorithms();
  std::vector<std::string> o = {"train.device=cpu", "train.torch_threads=1"};
  for (auto& e : extra) o.push_back(e);
  return rl::parse_train_config(
      rl::resolve_train_yaml(rl::default_train_config(algo), algo, "hand_over", o, kDataset),
      algo);
}

std::unique_ptr<offline::OfflineAlgorithm> make(const rl::TrainConfig& c, int64_t D, int64_t A) {
  auto a = rl::make_algorithm(c.algo, c, D, A, 4, torch::kCPU);
  auto* off = dynamic_cast<offline::OfflineAlgorithm*>(a.get());
  REQUIRE(off);
  a.release();
  return std::unique_ptr<offline::OfflineAlgorithm>(off);
}

// Small networks and few steps per update for each algorithm.
std::vector<std::string> small(const std::string& algo, int steps, int batch = 64) {
  std::vector<std::string> o = {algo + ".gradient_steps=" + std::to_string(steps),
                                algo + ".batch_size=" + std::to_string(batch)};
  if (algo == "bcq") {
    o.insert(o.end(), {"bcq.actor_hidden=[64, 64]", "bcq.critic_hidden=[64, 64]",
                       "bcq.vae_hidden=[64, 64]", "bcq.eval_candidates=20"});
  } else {
    o.push_back(algo + ".hidden=[64, 64]");
  }
  return o;
}

offline::Transitions empty_of(int64_t D, int64_t A) {
  offline::Transitions t;
  t.info.dataset_id = "synthetic/bandit-v0";
  t.info.task = "hand_over";
  t.info.obs_dim = D;
  t.info.act_dim = A;
  return t;
}

// One-step episodes (terminal): observation (s, u), s and u uniform in [-1, 1], the next
// observation zeros; a share `good` of the actions is the best one a*(s) = 0.5 s plus noise of
// std 0.05, the rest uniform in [-1, 1]; reward -(a - a*(s))^2.
offline::Transitions bandit(int64_t n, double good, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> uni(-1, 1);
  std::normal_distribution<float> noise(0, 0.05f);
  auto t = empty_of(2, 1);
  for (int64_t i = 0; i < n; ++i) {
    const float s = uni(rng), u = uni(rng), best = 0.5f * s;
    const float a = i < n * good ? std::clamp(best + noise(rng), -1.0f, 1.0f) : uni(rng);
    t.obs_row.push_back(int64_t(t.observations.size()) / 2);
    t.observations.insert(t.observations.end(), {s, u, 0, 0});
    t.actions.push_back(a);
    t.rewards.push_back(-(a - best) * (a - best));
    t.terminations.push_back(1);
    t.truncations.push_back(0);
  }
  t.steps = n;
  return t;
}

// Episodes of 4 steps, observations uniform in [-1, 1]^4 (every row, so the actions are a
// function of the observation row), actions W obs with W = [[0.3, -0.2, 0.1, 0], [0, 0.2, 0.2,
// -0.3]]; reward 0; the last step truncated.
offline::Transitions linear(int64_t episodes, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> uni(-1, 1);
  const float W[2][4] = {{0.3f, -0.2f, 0.1f, 0}, {0, 0.2f, 0.2f, -0.3f}};
  auto t = empty_of(4, 2);
  for (int64_t e = 0; e < episodes; ++e) {
    const int64_t first = int64_t(t.observations.size()) / 4;
    for (int k = 0; k < 5; ++k)
      for (int j = 0; j < 4; ++j) t.observations.push_back(uni(rng));
    for (int k = 0; k < 4; ++k) {
      const float* o = &t.observations[size_t(first + k) * 4];
      for (auto& w : W) t.actions.push_back(w[0] * o[0] + w[1] * o[1] + w[2] * o[2] + w[3] * o[3]);
      t.obs_row.push_back(first + k);
      t.rewards.push_back(0);
      t.terminations.push_back(0);
      t.truncations.push_back(k == 3);
    }
  }
  t.steps = episodes * 4;
  return t;
}

// Mean |pi(s) - a*(s)| of the bandit's deterministic policy over a grid of s (u = 0).
double bandit_error(offline::OfflineAlgorithm& a) {
  const auto s = torch::linspace(-1, 1, 41);
  const auto obs = torch::stack({s, torch::zeros_like(s)}, 1);
  return (a.actor(obs).squeeze(1) - 0.5 * s).abs().mean().item<double>();
}

std::string bytes(offline::OfflineAlgorithm& a) {
  torch::serialize::OutputArchive out;
  a.save(out);
  std::ostringstream s;
  out.save_to(s);
  return s.str();
}

void read(const std::string& b, torch::serialize::InputArchive& in) {
  std::istringstream s(b);
  in.load_from(s);
}

}  // namespace

TEST_CASE("the offline losses match hand-worked values", "[offline]") {
  auto T = [](std::vector<float> v, std::vector<int64_t> shape) {
    return torch::tensor(v).view(shape);
  };
  // BC: ((1 - 0)^2 + 0 + 0 + (0 - 2)^2) / 4 = 1.25
  CHECK(offline::bc_loss(T({1, 0, 0, 0}, {2, 2}), T({0, 0, 0, 2}, {2, 2})).item<double>() ==
        Approx(1.25));

  // TD3+BC: q = (1, -3): mean |q| = 2, lambda = alpha / 2 = 1 with alpha 2; -lambda mean q = 1;
  // BC term ((0.5 - 0)^2 + 0) / 2 = 0.125; loss 1.125. The gradient through q is -lambda / B
  // = -0.5 per row: lambda takes none.
  auto q = torch::tensor({1.0f, -3.0f}).requires_grad_(true);
  auto l = offline::td3bc_actor_loss(q, T({0.5, 0}, {2, 1}), T({0, 0}, {2, 1}), 2.0);
  CHECK(l.loss.item<double>() == Approx(1.125));
  CHECK(l.bc_mse.item<double>() == Approx(0.125));
  l.loss.backward();
  CHECK(q.grad()[0].item<double>() == Approx(-0.5));
  CHECK(q.grad()[1].item<double>() == Approx(-0.5));

  // BCQ's VAE: MSE ((0.5 - 1)^2 + 0) / 2 = 0.125; KL terms 1 + log std^2 - mean^2 - std^2:
  // (1 + 0 - 0 - 1) = 0 and (1 + log 4 - 1 - 4) = -2.613706, mean -1.306853, KL = 0.653426;
  // loss 0.125 + 0.5 x 0.653426 = 0.451713
  CHECK(offline::bcq_vae_loss(T({0.5, 0}, {1, 2}), T({1, 0}, {1, 2}), T({0, 1}, {1, 2}),
                              T({1, 2}, {1, 2}))
            .item<double>() == Approx(0.451713).epsilon(1e-5));

  // BCQ's target, 2 states x 2 samples, lmbda 0.75: (q1, q2) = (1, 2) -> 0.75 + 0.5 = 1.25,
  // (2, 0) -> 0 + 0.5 = 0.5, (3, 1) -> 0.75 + 0.75 = 1.5, (0, 4) -> 0 + 1 = 1; best per state
  // 1.25 and 1.5; reward (1, -1), not_done (1, 0), gamma 0.9: (1 + 0.9 x 1.25, -1) = (2.125, -1)
  const auto t = offline::bcq_target(T({1, 2, 3, 0}, {4}), T({2, 0, 1, 4}, {4}), 0.75,
                                     T({1, -1}, {2}), T({1, 0}, {2}), 0.9, 2);
  CHECK(t[0].item<double>() == Approx(2.125));
  CHECK(t[1].item<double>() == Approx(-1.0));

  // IQL's expectile loss, expectile 0.7: u = 2 -> 0.7 x 4 = 2.8; u = -1 -> 0.3 x 1 = 0.3;
  // mean 1.55
  CHECK(offline::iql_expectile_loss(T({2, -1}, {2}), 0.7).item<double>() == Approx(1.55));
  // IQL's weights, beta 3: exp(3 x 0.5) = 4.481689; exp(3 x 2) = 403.4 clipped to 100
  const auto w = offline::iql_policy_weights(T({1, 3}, {2}), T({0.5, 1}, {2}), 3.0, 100.0);
  CHECK(w[0].item<double>() == Approx(4.481689));
  CHECK(w[1].item<double>() == Approx(100.0));
  // IQL's log-density, log_var 0 (std 1): a = 0, mean 0: log N(0; 0, 1) = -0.918939 and
  // log(1 - 0) = 0; a = tanh(1) = 0.761594, mean 1: atanh a = 1, log N(1; 1, 1) = -0.918939,
  // log(1 - tanh(1)^2) = -0.867562, so -0.918939 + 0.867562 = -0.051377
  const auto lp = offline::iql_log_prob(T({0, float(std::tanh(1.0))}, {2, 1}), T({0, 1}, {2, 1}),
                                        torch::zeros({1}));
  CHECK(lp[0][0].item<double>() == Approx(-0.918939).epsilon(1e-5));
  CHECK(lp[1][0].item<double>() == Approx(-0.051377).epsilon(1e-4));
  // log_var log 4 (std 2), a = 0, mean 1: -0.5 x 1/4 - log 2 - 0.918939 = -1.737086
  CHECK(offline::iql_log_prob(T({0}, {1, 1}), T({1}, {1, 1}), torch::full({1}, std::log(4.0)))
            .item<double>() == Approx(-1.737086).epsilon(1e-5));
  // IQL's policy loss averages over rows and components: w (1, 2), log-probs ((-1, -3),
  // (0.5, 1)): -(-1 - 3 + 1 + 2) / 4 = 0.25
  CHECK(offline::iql_policy_loss(T({1, 2}, {2}), T({-1, -3, 0.5, 1}, {2, 2})).item<double>() ==
        Approx(0.25));
}

TEST_CASE("IQL's expectile loss is the original's |e u^2 + relu(-u) u| form", "[offline]") {
  torch::manual_seed(3);
  const auto u = torch::randn({1000}, torch::kFloat64) * 3;
  for (double e : {0.5, 0.7, 0.9}) {
    const auto original = (e * u.pow(2) + torch::relu(-u) * u).abs().mean();
    CHECK(offline::iql_expectile_loss(u, e).item<double>() ==
          Approx(original.item<double>()).epsilon(1e-12));
  }
}

TEST_CASE("BCQ acts by the candidate of the largest Q, row by row", "[offline]") {
  // candidates of 2 states x 3 samples x 2 components; the largest Q: sample 1, then sample 0
  const auto cand = torch::arange(12, torch::kFloat).view({2, 3, 2});
  const auto q = torch::tensor({{1.0f, 5.0f, 3.0f}, {7.0f, 2.0f, 0.0f}});
  const auto a = offline::bcq_pick(q, cand);
  REQUIRE(a.sizes() == torch::IntArrayRef({2, 2}));
  CHECK(a[0][0].item<float>() == 2);
  CHECK(a[0][1].item<float>() == 3);
  CHECK(a[1][0].item<float>() == 6);
  CHECK(a[1][1].item<float>() == 7);
}

TEST_CASE("bc, bcq, td3bc and iql are dataset algorithms with strict sections", "[offline]") {
  offline::register_algorithms();
  offline::register_algorithms();  // a second call does nothing
  const std::vector<std::pair<std::string, std::string>> titles = {
      {"bc", "BC"}, {"bcq", "BCQ"}, {"td3bc", "TD3+BC"}, {"iql", "IQL"}};
  for (const auto& [name, title] : titles) {
    INFO(name);
    const auto info = rl::find_algorithm(name);
    CHECK(info.title == title);
    CHECK(info.trains_on == rl::TrainsOn::kDataset);
    CHECK(info.section == name);
    CHECK_FALSE(info.meta);
    const auto c = config(name, {name + ".gradient_steps=7"});
    auto a = make(c, 2, 1);
    CHECK(a->steps_counted(256) == 7);
    CHECK(a->steps_per_update() == 1);  // the runner evaluates one episode length
    CHECK(a->metric_names().size() == (name == "bc" ? 1u : 4u));
    // no dataset yet: no update
    CHECK_THROWS_AS(a->update(torch::zeros({1, 2})), std::logic_error);
    try {
      rl::resolve_train_yaml(rl::default_train_config(name), name, "hand_over",
                             {name + ".gradient_steps=0"}, kDataset);
      FAIL("gradient_steps 0 accepted");
    } catch (const ConfigError& e) {
      CHECK_THAT(e.what(), Catch::Contains("gradient_steps"));
    }
    // a key the section does not have
    std::string text = rl::resolve_train_yaml(rl::default_train_config(name), name, "hand_over",
                                              {}, kDataset);
    const std::string key = "  obs_norm: true";
    const auto at = text.find(key);
    REQUIRE(at != std::string::npos);
    text.insert(at, "  extra_key: 1\n");
    try {
      rl::parse_train_config(text, "run.yaml");
      FAIL("unknown key accepted");
    } catch (const ConfigError& e) {
      CHECK_THAT(e.what(), Catch::Contains("extra_key"));
    }
  }
}

TEST_CASE("set_data refuses a dataset of another task or other widths, naming it",
          "[offline]") {
  for (const char* name : {"bc", "bcq", "td3bc", "iql"}) {
    INFO(name);
    auto a = make(config(name, small(name, 1)), 2, 1);
    auto d = bandit(16, 0.5, 1);
    d.info.task = "catch_underarm";
    try {
      a->set_data(d);
      FAIL("another task accepted");
    } catch (const offline::DatasetError& e) {
      CHECK_THAT(e.what(), Catch::Contains(kDataset) && Catch::Contains("hand_over") &&
                               Catch::Contains("catch_underarm"));
    }
    d = bandit(16, 0.5, 1);
    d.info.obs_dim = 3;
    try {
      a->set_data(d);
      FAIL("another observation width accepted");
    } catch (const offline::DatasetError& e) {
      CHECK_THAT(e.what(), Catch::Contains(kDataset) && Catch::Contains("obs_dim") &&
                               Catch::Contains("expected 2") && Catch::Contains("got 3"));
    }
    d = bandit(16, 0.5, 1);
    d.info.act_dim = 2;
    try {
      a->set_data(d);
      FAIL("another action width accepted");
    } catch (const offline::DatasetError& e) {
      CHECK_THAT(e.what(), Catch::Contains(kDataset) && Catch::Contains("act_dim") &&
                               Catch::Contains("expected 1") && Catch::Contains("got 2"));
    }
    d = bandit(16, 0.5, 1);
    d.obs_row.back() = 31;  // the last row has no next row
    CHECK_THROWS_AS(a->set_data(d), offline::DatasetError);
    a->set_data(bandit(16, 0.5, 1));
    CHECK(a->update(torch::zeros({1, 2})).size() == a->metric_names().size());
    CHECK(a->gradient_steps_done() == 1);
  }
}

TEST_CASE("a checkpoint resumes training exactly and load_actor acts as the saved run",
          "[offline]") {
  const auto data = bandit(256, 0.5, 2);
  const auto obs = torch::rand({5, 2}) * 2 - 1;
  for (const char* name : {"bc", "bcq", "td3bc", "iql"}) {
    INFO(name);
    const auto c = config(name, small(name, 5, 16));
    auto a = make(c, 2, 1);
    a->set_data(data);
    a->update(obs);
    const std::string saved = bytes(*a);

    // a fresh instance, loaded, continues as the original does from the same random state
    auto b = make(c, 2, 1);
    b->set_data(data);
    torch::serialize::InputArchive in;
    read(saved, in);
    b->load(in, "ckpt");
    CHECK(b->gradient_steps_done() == 5);
    torch::manual_seed(11);
    const auto ma = a->update(obs);
    torch::manual_seed(11);
    const auto mb = b->update(obs);
    for (size_t j = 0; j < ma.size(); ++j) CHECK(mb[j] == Approx(ma[j]).epsilon(1e-5));
    torch::manual_seed(12);
    const auto act_a = a->actor(obs);
    torch::manual_seed(12);
    CHECK(torch::allclose(b->actor(obs), act_a, 1e-5, 1e-6));

    // evaluation: a fresh instance that never saw the dataset, normaliser included
    auto e = make(c, 2, 1);
    torch::serialize::InputArchive in2;
    read(bytes(*a), in2);
    e->load_actor(in2, "ckpt");
    torch::manual_seed(13);
    const auto act_e = e->actor(obs);
    torch::manual_seed(13);
    CHECK(torch::allclose(act_e, a->actor(obs), 1e-6, 1e-6));
    CHECK(act_e.abs().max().item<double>() <= 1.0);
  }
}

TEST_CASE("BC fits actions that are a linear function of the observation", "[offline]") {
  torch::manual_seed(1);
  auto o = small("bc", 600, 128);
  o.push_back("bc.lr=1e-3");
  auto a = make(config("bc", o), 4, 2);
  a->set_data(linear(500, 3));
  const auto m = a->update(torch::zeros({1, 4}));
  // the actions' variance is about 0.05; held-out observations
  const auto test = linear(50, 4);
  const auto obs = torch::tensor(test.observations).view({-1, 4});
  const auto want = torch::tensor(test.actions).view({-1, 2});
  const auto rows = torch::tensor(test.obs_row);
  const double mse =
      (a->actor(obs.index_select(0, rows)) - want).pow(2).mean().item<double>();
  INFO("training bc_mse " << m[0] << ", held-out MSE " << mse);
  CHECK(mse < 2e-3);
}

TEST_CASE("TD3+BC, IQL and BCQ find a bandit's best action among random ones", "[offline]") {
  // 30% of the actions are the best one (plus noise), 70% uniform: the dataset's mean action
  // at s is 0.3 x 0.5 s, off the best by 0.7 x 0.5 |s|: 0.175 on average over s
  const auto data = bandit(4000, 0.3, 5);
  const double mean_error = 0.7 * 0.5 * 0.5;
  // (algorithm, gradient steps, an override): TD3+BC's actor steps every second step; IQL
  // also with its consistent tanh-Gaussian density
  const std::vector<std::tuple<std::string, int, std::string>> runs = {
      {"td3bc", 3000, ""}, {"iql", 1500, ""}, {"iql", 1500, "iql.double_tanh=false"},
      {"bcq", 1500, ""}};
  for (const auto& [name, steps, extra] : runs) {
    INFO(name << " " << extra);
    torch::manual_seed(2);
    auto o = small(name, steps, 128);
    if (!extra.empty()) o.push_back(extra);
    auto a = make(config(name, o), 2, 1);
    a->set_data(data);
    const auto m = a->update(torch::zeros({1, 2}));
    const double err = bandit_error(*a);
    INFO("mean |pi(s) - a*(s)| " << err << " (the dataset's mean action: " << mean_error
                                 << "); metrics " << m[0] << " " << m[1] << " " << m[2] << " "
                                 << m[3]);
    CHECK(err < 0.5 * mean_error);
  }
}
