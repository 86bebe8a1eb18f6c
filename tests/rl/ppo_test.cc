// The building blocks of PPO against hand-worked values: GAE with episode ends, the running
// normaliser, the Gaussian's density, entropy and KL, and PPO's update moving a policy towards
// better actions.
#include "tests/rl/rl_fixture.h"

#include <cmath>

#include "rl/policy.h"
#include "rl/ppo.h"

using namespace bidex;

TEST_CASE("GAE matches a hand-worked recursion and stops at episode ends", "[rl][ppo]") {
  // T = 3 steps of 2 slots; slot 1 ends its episode after step 0
  auto r = torch::tensor({{1.0f, 2.0f}, {0.5f, 1.0f}, {2.0f, 0.0f}});
  auto v = torch::tensor({{0.2f, 0.4f}, {0.3f, 0.1f}, {0.6f, 0.5f}});
  auto d = torch::tensor({{0.0f, 1.0f}, {0.0f, 0.0f}, {0.0f, 0.0f}});
  auto last = torch::tensor({0.7f, 0.9f});
  const double g = 0.9, l = 0.8;
  auto [adv, ret] = rl::gae(r, v, d, last, g, l);
  // slot 0, backwards
  const double d2 = 2.0 + g * 0.7 - 0.6, d1 = 0.5 + g * 0.6 - 0.3, d0 = 1.0 + g * 0.3 - 0.2;
  const double a2 = d2, a1 = d1 + g * l * a2, a0 = d0 + g * l * a1;
  CHECK(adv[2][0].item<double>() == Approx(a2).epsilon(1e-6));
  CHECK(adv[1][0].item<double>() == Approx(a1).epsilon(1e-6));
  CHECK(adv[0][0].item<double>() == Approx(a0).epsilon(1e-6));
  // slot 1: step 0 is the end of its episode: no bootstrap, no carry from step 1
  const double e2 = 0.0 + g * 0.9 - 0.5, e1 = 1.0 + g * 0.5 - 0.1;
  const double b2 = e2, b1 = e1 + g * l * b2, b0 = 2.0 - 0.4;
  CHECK(adv[1][1].item<double>() == Approx(b1).epsilon(1e-6));
  CHECK(adv[0][1].item<double>() == Approx(b0).epsilon(1e-6));
  CHECK(torch::allclose(ret, adv + v));
}

TEST_CASE("running normaliser equals the mean and variance of everything it saw", "[rl][ppo]") {
  torch::manual_seed(3);
  rl::RunningNorm n(3);
  std::vector<torch::Tensor> seen;
  for (int i = 0; i < 5; ++i) {
    auto x = torch::randn({7 + i, 3}, torch::kFloat64) * (i + 1) + i;
    n->update(x);
    seen.push_back(x);
  }
  auto all = torch::cat(seen);
  auto z = n->normalize(all);
  // normalised data has mean 0 and variance 1 (the tiny initial count shifts it by ~1e-6)
  CHECK(z.mean(0).abs().max().item<double>() < 1e-4);
  CHECK((z.var(0, false) - 1).abs().max().item<double>() < 1e-4);
  CHECK(n->count() == Approx(all.size(0)).epsilon(1e-5));
  // clamp at 5 standard deviations; denormalize inverts normalize inside the clamp
  auto far = all.mean(0, true) + 100 * all.std(0, true, true);
  CHECK(n->normalize(far).max().item<double>() == Approx(5.0));
  auto some = all.narrow(0, 0, 4);
  CHECK(torch::allclose(n->denormalize(n->normalize(some)), some, 1e-6, 1e-9));
}

TEST_CASE("Gaussian log-density, entropy and KL match their formulas", "[rl][ppo]") {
  auto mu = torch::tensor({{0.5f, -1.0f}});
  auto ls = torch::tensor({std::log(0.8f), std::log(2.0f)});
  auto a = torch::tensor({{1.0f, 0.0f}});
  const double lp = -0.5 * std::pow(0.5 / 0.8, 2) - std::log(0.8) - 0.5 * std::log(2 * M_PI) +
                    -0.5 * std::pow(1.0 / 2.0, 2) - std::log(2.0) - 0.5 * std::log(2 * M_PI);
  CHECK(rl::gaussian_log_prob(a, mu, ls).item<double>() == Approx(lp).epsilon(1e-5));
  const double h = 2 * (0.5 + 0.5 * std::log(2 * M_PI)) + std::log(0.8) + std::log(2.0);
  CHECK(rl::gaussian_entropy(ls).item<double>() == Approx(h).epsilon(1e-5));
  CHECK(rl::gaussian_kl(mu, ls, mu, ls).item<double>() == Approx(0).margin(1e-7));
  // KL(N(0,1) || N(1,2)) = log 2 + (1 + 1) / 8 - 1/2 per dimension
  auto z = torch::zeros({1, 1}), o = torch::ones({1, 1});
  auto kl = rl::gaussian_kl(z, torch::zeros({1}), o, torch::full({1}, std::log(2.0f)));
  CHECK(kl.item<double>() == Approx(std::log(2.0) + 2.0 / 8 - 0.5).epsilon(1e-5));
}

TEST_CASE("the actor-critic starts at the configured std with a small action mean", "[rl][ppo]") {
  rl::PpoConfig c;
  c.hidden = {64, 64};
  rl::ActorCritic m(10, 4, c);
  CHECK(torch::exp(m->log_std()).allclose(torch::full({4}, 0.8f)));
  torch::manual_seed(1);
  auto x = torch::randn({256, 10});
  // the output layer's gain 0.01 keeps the initial mean near zero
  CHECK(m->mean(x).abs().max().item<double>() < 0.1);
  CHECK(m->value(x).sizes() == torch::IntArrayRef({256}));
}

TEST_CASE("PPO updates raise the probability of better actions (one-step bandit)", "[rl][ppo]") {
  torch::manual_seed(5);
  rl::PpoConfig c;
  c.hidden = {32};
  c.epochs = 4;
  c.minibatches = 4;
  c.lr = 3e-3;
  c.schedule = "fixed";
  c.obs_norm = false;
  const int64_t T = 1, N = 256, D = 3, A = 2;
  rl::ActorCritic m(D, A, c);
  rl::Ppo ppo(m, c);
  auto mean_a0 = [&] {
    torch::NoGradGuard ng;
    return m->mean(torch::ones({1, D})).index({0, 0}).item<double>();
  };
  const double before = mean_a0();
  for (int it = 0; it < 15; ++it) {
    rl::Rollout r(T, N, D, A, torch::Device(torch::kCPU));
    torch::NoGradGuard ng;
    auto obs = torch::ones({N, D});
    auto mu = m->mean(obs);
    r.log_std.copy_(m->log_std());
    auto a = mu + torch::exp(r.log_std) * torch::randn_like(mu);
    r.nobs[0].copy_(obs);
    r.actions[0].copy_(a);
    r.mu[0].copy_(mu);
    r.values[0].copy_(m->value(obs));
    r.logp[0].copy_(rl::gaussian_log_prob(a, mu, r.log_std));
    r.rewards[0].copy_(a.select(1, 0));  // reward = first action: larger is better
    r.dones[0].fill_(1.0);
    torch::GradMode::set_enabled(true);
    auto st = ppo.update(r, torch::zeros({N}));
    torch::GradMode::set_enabled(false);
    CHECK(std::isfinite(st.policy_loss));
    CHECK(std::isfinite(st.kl));
  }
  CHECK(mean_a0() > before + 0.3);
}

TEST_CASE("the KL-adaptive learning rate falls on large steps and rises on small ones",
          "[rl][ppo]") {
  torch::manual_seed(2);
  rl::PpoConfig c;
  c.hidden = {16};
  c.epochs = 1;
  c.minibatches = 1;
  c.obs_norm = false;
  const int64_t N = 64, D = 2, A = 1;
  auto rollout = [&](rl::ActorCritic& m, double shift) {
    rl::Rollout r(1, N, D, A, torch::Device(torch::kCPU));
    torch::NoGradGuard ng;
    auto obs = torch::ones({N, D});
    auto mu = m->mean(obs);
    r.nobs[0].copy_(obs);
    r.log_std.copy_(m->log_std());
    r.mu[0].copy_(mu + shift);  // a behaviour policy `shift` away from the current one
    r.actions[0].copy_(mu);
    r.logp[0].copy_(rl::gaussian_log_prob(mu, mu + shift, r.log_std));
    r.rewards[0].copy_(torch::randn({N}));
    r.dones[0].fill_(1.0);
    return r;
  };
  {
    rl::ActorCritic m(D, A, c);
    rl::Ppo ppo(m, c);
    auto st = ppo.update(rollout(m, 1.0), torch::zeros({N}));  // KL = 1/(2 * 0.64) >> 0.032
    CHECK(st.lr == Approx(c.lr / 1.5));
  }
  {
    rl::ActorCritic m(D, A, c);
    rl::Ppo ppo(m, c);
    auto st = ppo.update(rollout(m, 0.01), torch::zeros({N}));  // KL ~ 8e-5 < 0.008
    CHECK(st.lr == Approx(c.lr * 1.5));
  }
}
