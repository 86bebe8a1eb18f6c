// rl/sac: the critics' target, the temperature's loss and the squashed Gaussian's density against
// hand-worked values, and a SAC run's checkpoints.
#include "tests/rl/rl_fixture.h"

#include <cmath>

#include "core/error.h"
#include "core/files.h"
#include "rl/checkpoint.h"
#include "rl/policy.h"
#include "rl/sac.h"
#include "rl/trainer.h"

using namespace bidex;

namespace {

// A small SAC run: 4 slots, 2 updates of 8 steps, networks of 32, on the CPU.
std::vector<std::string> tiny_sac() {
  return {"env.slots=4",           "env.threads=1",     "train.steps=64",
          "sac.hidden=[32]",       "sac.horizon=8",     "sac.minibatches=2",
          "sac.batch_size=16",     "sac.replay_size=64", "train.save_interval=1",
          "train.device=cpu",      "train.torch_threads=1"};
}

}  // namespace

TEST_CASE("SAC's critic target and temperature loss match hand-worked values", "[rl][sac]") {
  // two transitions: r = (1, -2), the second terminal; min(q1', q2') = (3, 4) minus
  // alpha log pi' = 0.5 x (-1, 2): y = 1 + 0.9 (3 + 0.5) = 4.15 and -2 (no bootstrap)
  const auto y = rl::sac_q_target(torch::tensor({1.0, -2.0}), torch::tensor({0.0, 1.0}),
                                  torch::tensor({3.0, 5.0}), torch::tensor({4.0, 4.0}),
                                  torch::tensor({-1.0, 2.0}), 0.5, 0.9);
  CHECK(y[0].item<double>() == Approx(4.15));
  CHECK(y[1].item<double>() == Approx(-2.0));
  // log alpha = log 0.2, log pi = (-3, -1), target entropy -2: -mean(log 0.2 x (-5, -3))
  //   = 4 log 0.2; its gradient -mean(log pi + target) = 4 > 0 lowers alpha: the entropy
  //   (-E log pi = 2) is above the target
  auto log_alpha = torch::full({1}, std::log(0.2)).set_requires_grad(true);
  auto loss = rl::sac_alpha_loss(log_alpha, torch::tensor({-3.0, -1.0}), -2.0);
  CHECK(loss.item<double>() == Approx(4 * std::log(0.2)));
  loss.backward();
  CHECK(log_alpha.grad()[0].item<double>() == Approx(4.0));
}

TEST_CASE("the squashed Gaussian's density is the Gaussian's with the change of variables",
          "[rl][sac]") {
  // one action dimension: u = 0.7, mean 0.2, std 0.5
  const double u = 0.7, m = 0.2, s = 0.5;
  const double gauss = -0.5 * std::pow((u - m) / s, 2) - std::log(s) - 0.5 * std::log(2 * M_PI);
  const double want = gauss - std::log(1 - std::pow(std::tanh(u), 2));
  const auto got = rl::tanh_gaussian_log_prob(torch::tensor({{u}}, torch::kFloat64),
                                              torch::tensor({{m}}, torch::kFloat64),
                                              torch::tensor({std::log(s)}, torch::kFloat64));
  CHECK(got[0].item<double>() == Approx(want).epsilon(1e-9));
  // far in the tail the stable form stays finite where log(1 - tanh^2) would be log 0
  const auto tail = rl::tanh_gaussian_log_prob(torch::tensor({{30.0}}, torch::kFloat64),
                                               torch::tensor({{30.0}}, torch::kFloat64),
                                               torch::tensor({0.0}, torch::kFloat64));
  CHECK(std::isfinite(tail[0].item<double>()));
}


TEST_CASE("a SAC run stops, resumes from its checkpoint and evaluates", "[rl][sac]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("sac");
  const std::vector<std::string> o = tiny_sac();
  const std::string yaml =
      rl::resolve_train_yaml(rl::default_train_config("sac"), "sac", "catch_underarm_raise", o);
  auto opt = test::quiet();
  opt.stop_after_updates = 1;
  auto r = rl::train_new(yaml, dir, opt);
  CHECK(r.updates == 1);
  CHECK(rl::read_checkpoint_meta(rl::list_checkpoints(dir).back()).algo == "sac");
  r = rl::train_resume(dir, test::quiet());
  CHECK(r.updates == 2);
  const std::string csv = read_file(dir + "/metrics.csv");
  for (const char* c : {"q_loss", "actor_loss", "alpha_loss", "entropy", "q_mean", "alpha"})
    CHECK(csv.find(c) != std::string::npos);
  rl::LoadedPolicy p(dir);
  const auto e = rl::evaluate(p, 4, 3, 1);
  CHECK(e.episodes == 4);
  CHECK(std::isfinite(e.mean_return));
  // a replay buffer smaller than one step of every slot is refused, naming the key
  try {
    rl::resolve_train_yaml(rl::default_train_config("sac"), "sac", "catch_underarm_raise",
                           {"env.slots=64", "sac.replay_size=10"});
    FAIL("accepted");
  } catch (const ConfigError& err) {
    CHECK(err.key() == "sac.replay_size");
    CHECK(std::string(err.what()).find("at least env.slots (64)") != std::string::npos);
  }
}

TEST_CASE("multi-task SAC: each task's temperature follows its own rows", "[rl][sac][mtsac]") {
  // two tasks; the last two columns are the one-hot id: row 0 is task 1, row 1 task 0
  const auto obs = torch::tensor({{0.3, 0.0, 1.0}, {-0.2, 1.0, 0.0}});
  const auto ids = rl::task_ids(obs, 2);
  CHECK(ids[0].item<int64_t>() == 1);
  CHECK(ids[1].item<int64_t>() == 0);
  // log alpha = (log 0.5, log 2); logp = (-3, -1), target entropy -2:
  // loss = -mean(la[id] (logp - 2)) = -(log 2 x -5 + log 0.5 x -3) / 2, and its gradient reaches
  // each task's temperature through its own row only: d/d la0 = 3/2 (row 1), d/d la1 = 5/2 (row 0)
  auto la = torch::tensor({std::log(0.5), std::log(2.0)}, torch::kFloat64).set_requires_grad(true);
  auto loss = rl::sac_alpha_loss(la.index_select(0, ids), torch::tensor({-3.0, -1.0},
                                 torch::kFloat64), -2.0);
  CHECK(loss.item<double>() == Approx(-(std::log(2.0) * -5 + std::log(0.5) * -3) / 2));
  loss.backward();
  CHECK(la.grad()[0].item<double>() == Approx(1.5));
  CHECK(la.grad()[1].item<double>() == Approx(2.5));
  // the target with each row's temperature: 1 + 0.5 (min(2, 3) + 0.5 x 1) = 2.25 and
  // 1 + 0.5 (min(2, 1) + 2 x 2) = 3.5
  const auto y = rl::sac_q_target(torch::tensor({1.0, 1.0}), torch::tensor({0.0, 0.0}),
                                  torch::tensor({2.0, 2.0}), torch::tensor({3.0, 1.0}),
                                  torch::tensor({-1.0, -2.0}), torch::tensor({0.5, 2.0}), 0.5);
  CHECK(y[0].item<float>() == Approx(2.25));
  CHECK(y[1].item<float>() == Approx(3.5));
}

TEST_CASE("an MTSAC run on a suite trains, resumes and evaluates per task", "[rl][sac][mtsac]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("mtsac");
  const std::vector<std::string> o = tiny_sac();
  const std::string yaml =
      rl::resolve_train_yaml(rl::default_train_config("mtsac"), "mtsac", "MT4", o);
  CHECK(yaml.find("suite: MT4") != std::string::npos);
  auto opt = test::quiet();
  opt.stop_after_updates = 1;
  auto r = rl::train_new(yaml, dir, opt);
  CHECK(rl::read_checkpoint_meta(rl::list_checkpoints(dir).back()).algo == "mtsac");
  r = rl::train_resume(dir, test::quiet());
  CHECK(r.updates == 2);
  const std::string csv = read_file(dir + "/metrics.csv");
  for (const char* c : {"return_hand_over", "alpha", "alpha_loss"})
    CHECK(csv.find(c) != std::string::npos);
  rl::LoadedPolicy p(dir);
  const auto e = rl::evaluate(p, 2, 3, 1);
  CHECK(e.per_task.size() == 4);
}
