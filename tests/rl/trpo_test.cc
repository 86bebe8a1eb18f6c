// rl/trpo: conjugate gradient and the line search against hand-worked cases, TRPO's step within
// its KL bound towards better actions, and a TRPO run's checkpoints.
#include "tests/rl/rl_fixture.h"

#include "core/error.h"
#include "core/files.h"
#include "rl/algorithm.h"
#include "rl/checkpoint.h"
#include "rl/trainer.h"
#include "rl/trpo.h"

using namespace bidex;

TEST_CASE("conjugate gradient solves a known system, one step the steepest-descent point",
          "[rl][trpo]") {
  const auto A =
      torch::tensor({{4.0, 1.0, 0.0}, {1.0, 3.0, 1.0}, {0.0, 1.0, 2.0}}, torch::kFloat64);
  const auto b = torch::tensor({1.0, 2.0, 3.0}, torch::kFloat64);
  int products = 0;
  auto Avp = [&](const torch::Tensor& v) {
    ++products;
    return torch::mv(A, v);
  };
  // three iterations solve a 3 x 3 system exactly: A^-1 b = (2/9, 1/9, 13/9)
  const auto x = rl::conjugate_gradient(Avp, b, 3);
  CHECK(x[0].item<double>() == Approx(2.0 / 9).margin(1e-9));
  CHECK(x[1].item<double>() == Approx(1.0 / 9).margin(1e-9));
  CHECK(x[2].item<double>() == Approx(13.0 / 9).margin(1e-9));
  CHECK(products == 3);
  // one iteration: x = (b.b / b.A b) b = 14/50 b
  const auto x1 = rl::conjugate_gradient(Avp, b, 1);
  for (int i = 0; i < 3; ++i) CHECK(x1[i].item<double>() == Approx(0.28 * (i + 1)));
  // a zero right-hand side stops at once
  products = 0;
  const auto zero = rl::conjugate_gradient(Avp, torch::zeros({3}, torch::kFloat64), 5);
  CHECK(zero.abs().sum().item<double>() == 0);
  CHECK(products == 0);
}

TEST_CASE("the line search halves the step until the KL bound and a real improvement hold",
          "[rl][trpo]") {
  // loss (x - 3)^2 from x0 = 0 along a full step of 8; the linear model predicts 6 x 8 = 48
  auto loss = [](const torch::Tensor& x) { return std::pow(x.item<double>() - 3, 2); };
  auto kl = [](const torch::Tensor& x) { return std::pow(x.item<double>(), 2); };
  const auto x0 = torch::zeros({1}, torch::kFloat64), step = torch::full({1}, 8.0, torch::kFloat64);
  // no KL bound in the way: 8 makes it worse (25 > 9), 4 improves by 8 > 0.01 x 24
  auto free = rl::backtracking_line_search(loss, kl, x0, step, 48, 1e9, 10, 0.01);
  CHECK(free.accepted);
  CHECK(free.fraction == 0.5);
  CHECK(free.params.item<double>() == 4);
  CHECK(free.improvement == Approx(8));
  // KL bound 4 (x^2 <= 4): 4 is refused, 2 taken (loss 1)
  auto bounded = rl::backtracking_line_search(loss, kl, x0, step, 48, 4, 10, 0.01);
  CHECK(bounded.fraction == 0.25);
  CHECK(bounded.params.item<double>() == 2);
  // three trials, none improving by 0.9 of the prediction (8: worse; 4: 8 < 21.6; 2: 8 < 10.8),
  // keep x0
  auto none = rl::backtracking_line_search(loss, kl, x0, step, 48, 1e9, 3, 0.9);
  CHECK_FALSE(none.accepted);
  CHECK(none.fraction == 0);
  CHECK(none.params.item<double>() == 0);
}

TEST_CASE("TRPO steps within its KL bound and raises the probability of better actions",
          "[rl][trpo]") {
  torch::manual_seed(7);
  rl::TrainConfig c;
  c.algo = "trpo";
  c.ppo.hidden = {32};
  c.ppo.horizon = 1;
  c.ppo.epochs = 2;
  c.ppo.minibatches = 2;
  c.ppo.obs_norm = false;
  c.ppo.lr = 1e-3;
  c.trpo.max_kl = 0.01;
  const int64_t N = 256, D = 3, A = 2;
  auto algo = rl::make_algorithm("trpo", c, D, A, N, torch::Device(torch::kCPU));
  REQUIRE(algo->metric_names().size() == 6);
  CHECK(algo->metric_names()[4] == "step_fraction");
  const auto obs = torch::ones({N, D});
  auto mean_a0 = [&] { return algo->actor(obs.narrow(0, 0, 1))[0][0].item<double>(); };
  const double before = mean_a0();
  for (int it = 0; it < 10; ++it) {
    const auto a = algo->act(obs);
    rl::Transition t;
    t.obs = obs;
    t.reward = a.select(1, 0).clone();  // reward = first action: larger is better
    t.done = torch::ones({N});
    t.final_ids = torch::zeros({0}, torch::kLong);
    t.final_obs = torch::zeros({0, D});
    algo->observe(t);
    const auto m = algo->update(obs);
    INFO("update " << it << ": kl " << m[3] << ", step fraction " << m[4]);
    CHECK(m[3] <= 0.01 * 1.0001);  // the mean KL after the step, within the bound
    CHECK(m[4] > 0);               // a step was taken
    CHECK(std::isfinite(m[1]));
  }
  CHECK(mean_a0() > before + 0.1);
}


TEST_CASE(
    "a TRPO run stops, resumes from its checkpoint and evaluates, and PPO's state is refused",
    "[rl][trpo]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("trpo"), ppo_dir = tmp.file("ppo");
  auto o = test::quiet();
  o.stop_after_updates = 1;
  auto r = rl::train_new(test::tiny_onpolicy_yaml("trpo", "catch_underarm_raise"), dir, o);
  CHECK(r.interrupted);
  CHECK(r.updates == 1);
  CHECK(rl::read_checkpoint_meta(rl::list_checkpoints(dir).back()).algo == "trpo");
  r = rl::train_resume(dir, test::quiet());
  CHECK(r.updates == 2);
  CHECK_FALSE(r.interrupted);
  // the metrics have TRPO's columns; the step was taken within its bound
  const std::string csv = read_file(dir + "/metrics.csv");
  CHECK(csv.find("step_fraction") != std::string::npos);
  CHECK(csv.find("clip_fraction") == std::string::npos);
  rl::LoadedPolicy p(dir);
  CHECK(p.update() == 2);
  const auto e = rl::evaluate(p, 4, 3, 1);
  CHECK(e.episodes == 4);
  CHECK(std::isfinite(e.mean_return));
  // a PPO checkpoint of the same task and shapes is another algorithm's state
  rl::train_new(test::tiny_yaml("catch_underarm_raise"), ppo_dir, test::quiet());
  const std::string ck = rl::list_checkpoints(ppo_dir).back();
  try {
    rl::LoadedPolicy q(dir, ck);
    FAIL("loaded");
  } catch (const Error& err) {
    const std::string msg = err.what();
    CHECK(msg.find("holds the state of algorithm ppo") != std::string::npos);
    CHECK(msg.find("trains with trpo") != std::string::npos);
  }
}
