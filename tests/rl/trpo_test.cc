// rl/trpo: conjugate gradient and the line search against hand-worked cases, TRPO's step within
// its KL bound towards better actions, a TRPO run's checkpoints, and its update with FlatAdam for
// the critic against the same update with LibTorch's Adam.
#include "tests/rl/mirror_fixture.h"

#include "core/error.h"
#include "core/files.h"
#include "rl/algorithm.h"
#include "rl/checkpoint.h"
#include "rl/policy.h"
#include "rl/ppo.h"
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

namespace {

// TRPO's update (rl/trpo.cc) as it was with LibTorch's Adam and clip_grad_norm_ for the critic,
// on a copy of the learner's actor-critic read from its checkpoint state, with the rollout the
// learner recorded (GaussianOnPolicy: observations not normalised here, no value normalisation).
struct TrpoMirror {
  TrpoMirror(const rl::TrainConfig& config, int64_t D, int64_t A,
             torch::serialize::InputArchive& root)
      : c(config.ppo), model(D, A, config.ppo) {
    REQUIRE_FALSE(c.obs_norm);
    REQUIRE_FALSE(c.value_norm);
    const rl::TrpoConfig& t = config.trpo;
    settings = {t.max_kl, t.damping, t.cg_iters, t.backtracks, t.accept_ratio, t.step_fraction};
    test::load_part(root, "model", *model);
    critic_opt = std::make_unique<torch::optim::Adam>(model->critic_parameters(),
                                                      torch::optim::AdamOptions(c.lr));
  }

  // What GaussianOnPolicy's act() and observe() record of one step: `actions` (the learner's) on
  // `obs`, and the transition `t`.
  void record(const torch::Tensor& obs, const torch::Tensor& actions, const rl::Transition& t) {
    torch::NoGradGuard ng;
    if (obs_.empty()) log_std = model->log_std().detach().clone();
    const auto mu = model->mean(obs);
    obs_.push_back(obs);
    actions_.push_back(actions);
    mu_.push_back(mu);
    values_.push_back(model->value(obs));
    logp_.push_back(rl::gaussian_log_prob(actions, mu, log_std));
    rewards_.push_back(
        t.reward.clone().index_add_(0, t.final_ids, c.gamma * model->value(t.final_obs)));
    dones_.push_back(t.done.clone());
  }

  // policy_loss, value_loss, entropy, kl, step_fraction: TrpoAlgorithm::update's first five
  std::vector<double> update(const torch::Tensor& last_obs) {
    torch::Tensor last_value;
    {
      torch::NoGradGuard ng;
      last_value = model->value(last_obs);
    }
    auto [adv, ret] = rl::gae(torch::stack(rewards_), torch::stack(values_), torch::stack(dones_),
                              last_value, c.gamma, c.lambda);
    const int64_t B = adv.numel();
    const auto nobs = torch::stack(obs_).reshape({B, -1});
    const auto actions = torch::stack(actions_).reshape({B, -1});
    const auto logp_old = torch::stack(logp_).reshape({B});
    const auto mu_old = torch::stack(mu_).reshape({B, -1});
    auto advantages = adv.reshape({B});
    advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8);
    auto surrogate = [&] {
      auto logp = rl::gaussian_log_prob(actions, model->mean(nobs), model->log_std());
      return -(torch::exp(logp - logp_old) * advantages).mean();
    };
    auto mean_kl = [&] {
      return rl::gaussian_kl(mu_old, log_std, model->mean(nobs), model->log_std()).mean();
    };
    const rl::NaturalStep step =
        rl::natural_step(model->actor_parameters(), surrogate, mean_kl, settings);
    const auto targets = ret.reshape({B});
    const int64_t mb = B / c.minibatches;
    double value_sum = 0;
    int n = 0;
    for (int epoch = 0; epoch < c.epochs; ++epoch) {
      const auto perm = torch::randperm(B, torch::TensorOptions().dtype(torch::kLong));
      for (int k = 0; k < c.minibatches; ++k) {
        const auto idx = perm.narrow(0, k * mb, mb);
        auto value_loss = (model->raw_value(nobs.index_select(0, idx)) -
                           targets.index_select(0, idx)).pow(2).mean();
        critic_opt->zero_grad();
        (c.value_coef * value_loss).backward();
        critic_norms.push_back(
            torch::nn::utils::clip_grad_norm_(model->critic_parameters(), c.max_grad_norm));
        critic_opt->step();
        value_sum += value_loss.item<double>();
        ++n;
      }
    }
    for (auto* v : {&obs_, &actions_, &mu_, &values_, &logp_, &rewards_, &dones_}) v->clear();
    return {step.loss, value_sum / n, rl::gaussian_entropy(model->log_std()).item<double>(),
            step.kl, step.fraction};
  }

  rl::PpoConfig c;
  rl::NaturalStepSettings settings;
  rl::ActorCritic model;
  std::unique_ptr<torch::optim::Adam> critic_opt;
  std::vector<double> critic_norms;  // the clip's norms
  torch::Tensor log_std;      // the rollout's
  std::vector<torch::Tensor> obs_, actions_, mu_, values_, logp_, rewards_, dones_;
};

}  // namespace

TEST_CASE("TRPO's critic with FlatAdam steps as LibTorch's Adam with clip_grad_norm_ did",
          "[rl][trpo][flat_adam]") {
  rl::TrainConfig c;
  c.algo = "trpo";
  c.ppo.hidden = {32};
  c.ppo.horizon = 4;
  c.ppo.epochs = 2;
  c.ppo.minibatches = 2;
  c.ppo.obs_norm = false;
  c.ppo.lr = 1e-3;
  c.ppo.max_grad_norm = 3.0;  // binds on some steps only
  const int64_t N = 16, D = 4, A = 2;
  torch::manual_seed(3);
  auto alg = rl::make_algorithm("trpo", c, D, A, N, torch::Device(torch::kCPU));
  auto start = test::saved_state(*alg);
  TrpoMirror mirror(c, D, A, start);
  std::vector<torch::Tensor> critic_start;
  for (auto& p : mirror.model->critic_parameters()) critic_start.push_back(p.detach().clone());
  // two updates of a rollout of 4 steps, each from the same seed
  auto obs = torch::randn({N, D});
  for (int u = 0; u < 2; ++u) {
    for (int t = 0; t < c.ppo.horizon; ++t) {
      const auto a = alg->act(obs);
      rl::Transition tr;
      tr.obs = torch::randn({N, D});
      tr.reward = a.select(1, 0) + 0.1 * torch::randn({N});
      // slot 1's episode ends by itself, slot 2's at its time limit (bootstrapped)
      tr.done = torch::zeros({N});
      tr.done.narrow(0, 1, 2).fill_(1);
      tr.final_ids = torch::tensor({int64_t(2)});
      tr.final_obs = torch::randn({1, D});
      mirror.record(obs, a, tr);
      alg->observe(tr);
      obs = tr.obs;
    }
    torch::manual_seed(100 + u);
    const auto got = alg->update(obs);
    torch::manual_seed(100 + u);
    const auto want = mirror.update(obs);
    for (size_t i = 0; i < want.size(); ++i) {
      INFO("update " << u << ", " << alg->metric_names()[i]);
      CHECK(got[i] == Approx(want[i]).epsilon(1e-4).margin(1e-5));
    }
    CHECK(got[4] > 0);  // the policy stepped
  }
  test::check_clips(mirror.critic_norms, {}, c.ppo.max_grad_norm);
  auto after = test::saved_state(*alg);
  rl::ActorCritic model(D, A, c.ppo);
  test::load_part(after, "model", *model);
  CHECK(test::max_param_diff(*model, *mirror.model) < test::kMirrorTol);
  CHECK(test::max_diff(critic_start, model->critic_parameters()) > 100 * test::kMirrorTol);
}
