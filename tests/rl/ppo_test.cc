// The building blocks of PPO against hand-worked values: GAE with episode ends, the running
// normaliser, the Gaussian's density, entropy and KL, and PPO's update moving a policy towards
// better actions. The update on the device (FlatAdam, the KL-adaptive rate without a read back)
// against the update as it ran with LibTorch's Adam and the host's rule, and a PPO run saved and
// loaded against the unbroken run.
#include "tests/rl/mirror_fixture.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>

#include "rl/algorithm.h"
#include "rl/autocast.h"
#include "rl/flat_adam.h"
#include "rl/onpolicy.h"
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

namespace {

// A one-step bandit whose reward is the first action: 15 PPO updates of 256 slots from seed 5,
// with `bf16` for the update's products. Returns how far the first action's mean rose.
double bandit_gain(bool bf16) {
  torch::manual_seed(5);
  rl::PpoConfig c;
  c.hidden = {32};
  c.epochs = 4;
  c.minibatches = 4;
  c.lr = 3e-3;
  c.schedule = "fixed";
  c.obs_norm = false;
  c.bf16 = bf16;
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
  return mean_a0() - before;
}

}  // namespace

TEST_CASE("PPO updates raise the probability of better actions (one-step bandit)", "[rl][ppo]") {
  CHECK(bandit_gain(false) > 0.3);
}

TEST_CASE("advantages are normalised over the update or within each task", "[rl][ppo]") {
  torch::manual_seed(3);
  // three tasks of very different reward scales, one of a single row
  auto adv = torch::cat({torch::randn({5}) * 100 + 40, torch::randn({6}) * 0.1 - 2,
                         torch::randn({1})});
  auto groups = torch::tensor({0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 2}, torch::kLong);
  // over the update: the formula PPO always had
  auto all = rl::normalize_advantages(adv);
  CHECK(torch::equal(all, (adv - adv.mean()) / (adv.std() + 1e-8)));
  // one group holding every row: the same, within rounding
  CHECK(torch::allclose(rl::normalize_advantages(adv, torch::zeros({12}, torch::kLong), 1), all,
                        1e-5, 1e-6));
  // per task: each task's rows by hand, mean 0 and unbiased std 1 each
  auto per = rl::normalize_advantages(adv, groups, 3);
  for (auto [first, n] : {std::pair<int64_t, int64_t>{0, 5}, {5, 6}}) {
    auto a = adv.narrow(0, first, n);
    auto want = (a - a.mean()) / (a.std() + 1e-8);
    CHECK(torch::allclose(per.narrow(0, first, n), want, 1e-5, 1e-6));
    CHECK(per.narrow(0, first, n).mean().item<double>() == Approx(0).margin(1e-5));
    CHECK(per.narrow(0, first, n).std().item<double>() == Approx(1).epsilon(1e-4));
  }
  CHECK(per[11].item<double>() == 0.0);  // a lone row: its advantage less its own mean
  // the small task's signal survives: over the update it is swamped by the large task's spread
  CHECK(all.narrow(0, 5, 6).std().item<double>() < 0.01);
  // task ids from the one-hot's columns, raw or normalised by a running mean and std
  auto onehot = torch::eye(3).index_select(0, groups);
  auto normalised = (onehot - onehot.mean(0)) / onehot.std(0);
  CHECK(torch::equal(rl::task_ids(torch::cat({torch::randn({12, 4}), onehot}, 1), 3), groups));
  CHECK(torch::equal(rl::task_ids(torch::cat({torch::randn({12, 4}), normalised}, 1), 3), groups));
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

TEST_CASE("the device's adaptive learning rate follows the host rule", "[rl][ppo]") {
  const double d = 0.016;
  // PPO's rule as it ran on the host: the KL read back as a double
  auto host = [&](double lr, float kl) {
    if (kl > 2.0 * d) return std::max(1e-5, lr / 1.5);
    if (kl < 0.5 * d && kl > 0.0) return std::min(1e-2, lr * 1.5);
    return lr;
  };
  const float twice = float(2.0 * d), half = float(0.5 * d);
  // nextafter: the floats on either side of the thresholds as the double compares them
  const std::vector<float> kls = {0.0f,
                                  twice,
                                  std::nextafter(twice, 1.0f),
                                  std::nextafter(twice, 0.0f),
                                  half,
                                  std::nextafter(half, 0.0f),
                                  std::nextafter(half, 1.0f),
                                  1e-30f,
                                  -1e-3f,
                                  0.02f,
                                  1.0f,
                                  std::nanf("")};
  for (double start : {3e-4, 1.2e-5, 1e-5, 8e-3, 1e-2}) {
    for (float kl : kls) {
      auto lr = torch::scalar_tensor(start, torch::kFloat64);
      rl::adapt_lr(lr, torch::scalar_tensor(kl, torch::kFloat32), d);
      INFO("lr " << start << " kl " << kl);
      CHECK(lr.item<double>() == host(start, kl));
    }
  }
  // a sequence, each step from the last
  auto lr = torch::scalar_tensor(3e-4, torch::kFloat64);
  double want = 3e-4;
  for (int k = 0; k < 40; ++k) {
    const float kl = k < 20 ? 0.5f : 1e-4f;  // down to the floor, then up to the cap
    rl::adapt_lr(lr, torch::scalar_tensor(kl, torch::kFloat32), d);
    want = host(want, kl);
    CHECK(lr.item<double>() == want);
  }
  CHECK(want == 1e-2);
}

namespace {

// PPO's update as it ran before FlatAdam, written out independently: LibTorch's Adam, its
// clip_grad_norm_, and the KL read back each minibatch for the adaptive learning rate on the
// host. Keeps Adam and the rate across updates; records the rate of every minibatch.
struct ReferencePpo {
  ReferencePpo(rl::ActorCritic model, const rl::PpoConfig& config)
      : m(model), c(config), opt(m->parameters(), torch::optim::AdamOptions(c.lr)), lr(c.lr) {}

  rl::UpdateStats update(const rl::Rollout& r, const torch::Tensor& last_value) {
    auto [adv, ret] = rl::gae(r.rewards, r.values, r.dones, last_value, c.gamma, c.lambda);
    const int64_t B = r.horizon * r.nslot;
    auto nobs = r.nobs.reshape({B, -1}), actions = r.actions.reshape({B, -1});
    auto logp_old = r.logp.reshape({B}), mu_old = r.mu.reshape({B, -1});
    auto values_old = r.values.reshape({B}), returns = ret.reshape({B});
    auto advantages = adv.reshape({B});
    advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8);
    torch::Tensor targets = returns, values_old_raw = values_old;
    if (m->uses_value_norm()) {
      m->value_norm()->update(returns.unsqueeze(1));
      torch::NoGradGuard ng;
      targets = m->value_norm()->normalize(returns.unsqueeze(1)).squeeze(1);
      values_old_raw = m->value_norm()->normalize(values_old.unsqueeze(1)).squeeze(1);
    }
    const int64_t mb = B / c.minibatches;
    rl::UpdateStats st;
    int n = 0;
    for (int epoch = 0; epoch < c.epochs; ++epoch) {
      auto perm = torch::randperm(B, torch::kLong);
      for (int k = 0; k < c.minibatches; ++k) {
        auto idx = perm.narrow(0, k * mb, mb);
        auto o = nobs.index_select(0, idx);
        auto mu = m->mean(o);
        auto log_std = m->log_std();
        auto logp = rl::gaussian_log_prob(actions.index_select(0, idx), mu, log_std);
        double kl = 0;
        {
          torch::NoGradGuard ng;
          kl = rl::gaussian_kl(mu_old.index_select(0, idx), r.log_std, mu, log_std)
                   .mean()
                   .item<double>();
        }
        if (kl > 2.0 * c.desired_kl) lr = std::max(1e-5, lr / 1.5);
        else if (kl < 0.5 * c.desired_kl && kl > 0.0) lr = std::min(1e-2, lr * 1.5);
        lrs.push_back(lr);
        for (auto& g : opt.param_groups())
          static_cast<torch::optim::AdamOptions&>(g.options()).lr(lr);
        auto ratio = torch::exp(logp - logp_old.index_select(0, idx));
        auto policy_loss = rl::clipped_surrogate(ratio, advantages.index_select(0, idx), c.clip);
        auto v = m->raw_value(o);
        auto tgt = targets.index_select(0, idx);
        auto v_old = values_old_raw.index_select(0, idx);
        auto v_clipped = v_old + torch::clamp(v - v_old, -c.value_clip, c.value_clip);
        auto value_loss = torch::max((v - tgt).pow(2), (v_clipped - tgt).pow(2)).mean();
        auto entropy = rl::gaussian_entropy(log_std);
        auto loss = policy_loss + c.value_coef * value_loss - c.entropy_coef * entropy;
        opt.zero_grad();
        loss.backward();
        norms.push_back(torch::nn::utils::clip_grad_norm_(m->parameters(), c.max_grad_norm));
        opt.step();
        st.policy_loss += policy_loss.item<double>();
        st.value_loss += value_loss.item<double>();
        st.entropy += entropy.item<double>();
        st.clip_fraction +=
            ((ratio - 1.0).abs() > c.clip).to(torch::kFloat32).mean().item<double>();
        st.kl += kl;
        ++n;
      }
    }
    for (double* s : {&st.policy_loss, &st.value_loss, &st.entropy, &st.clip_fraction, &st.kl})
      *s /= n;
    st.lr = lr;
    return st;
  }

  rl::ActorCritic m;
  rl::PpoConfig c;
  torch::optim::Adam opt;
  double lr;
  std::vector<double> lrs, norms;
};

// A rollout of the policy `m` with its means moved by noise (a behaviour policy near it, so
// that the KL varies), random rewards and episode ends.
rl::Rollout noisy_rollout(rl::ActorCritic& m, int64_t T, int64_t N, int64_t D, int64_t A,
                          double noise) {
  rl::Rollout r(T, N, D, A, torch::Device(torch::kCPU));
  torch::NoGradGuard ng;
  r.log_std.copy_(m->log_std());
  auto obs = torch::randn({T, N, D});
  auto mu = m->mean(obs) + noise * torch::randn({T, N, A});
  auto a = mu + torch::exp(r.log_std) * torch::randn({T, N, A});
  r.nobs.copy_(obs);
  r.actions.copy_(a);
  r.mu.copy_(mu);
  r.values.copy_(m->value(obs));
  r.logp.copy_(rl::gaussian_log_prob(a, mu, r.log_std));
  r.rewards.copy_(torch::randn({T, N}));
  r.dones.copy_((torch::rand({T, N}) < 0.1).to(torch::kFloat32));
  return r;
}

}  // namespace

TEST_CASE("PPO's update equals the update with LibTorch's Adam and the host's KL rule",
          "[rl][ppo]") {
  rl::PpoConfig c;
  c.hidden = {16};
  c.epochs = 3;
  c.minibatches = 4;
  c.obs_norm = false;
  c.value_norm = true;
  c.clip_value_loss = true;
  c.entropy_coef = 0.01;
  c.lr = 3e-3;
  c.desired_kl = 0.004;
  c.max_grad_norm = 1.5;
  const int64_t T = 4, N = 32, D = 3, A = 2;
  torch::manual_seed(11);
  rl::ActorCritic m(D, A, c);
  torch::manual_seed(11);
  rl::ActorCritic ref_m(D, A, c);
  rl::Ppo ppo(m, c);
  ReferencePpo ref(ref_m, c);
  REQUIRE(test::max_param_diff(*m, *ref_m) == 0);
  for (int u = 0; u < 3; ++u) {
    torch::manual_seed(20 + u);
    const auto r = noisy_rollout(ref_m, T, N, D, A, u == 0 ? 0.3 : 0.02);
    const auto last = torch::randn({N});
    torch::manual_seed(30 + u);  // the same minibatches
    const auto st = ppo.update(r, last);
    torch::manual_seed(30 + u);
    const auto want = ref.update(r, last);
    INFO("update " << u);
    CHECK(test::max_param_diff(*m, *ref_m) < 1e-6);  // float rounding (3e-8 seen); a step moves ~lr
    CHECK(st.policy_loss == Approx(want.policy_loss).epsilon(1e-5).margin(1e-7));
    CHECK(st.value_loss == Approx(want.value_loss).epsilon(1e-5));
    CHECK(st.entropy == Approx(want.entropy).epsilon(1e-5));
    CHECK(st.kl == Approx(want.kl).epsilon(1e-4).margin(1e-9));
    CHECK(st.clip_fraction == Approx(want.clip_fraction).margin(1e-9));
    CHECK(st.lr == Approx(want.lr).epsilon(1e-12));
  }
  // the rate fell and rose (up to its cap), and the clip bound and did not
  bool fell = false, rose = false;
  for (size_t k = 1; k < ref.lrs.size(); ++k) {
    fell = fell || ref.lrs[k] < ref.lrs[k - 1];
    rose = rose || ref.lrs[k] > ref.lrs[k - 1];
  }
  CHECK(fell);
  CHECK(rose);
  CHECK(*std::max_element(ref.lrs.begin(), ref.lrs.end()) == 1e-2);
  CHECK(*std::max_element(ref.norms.begin(), ref.norms.end()) > c.max_grad_norm);
  CHECK(*std::min_element(ref.norms.begin(), ref.norms.end()) < c.max_grad_norm);
  // no host synchronisation inside the epochs: one read of the statistics per update
  ppo.timer().enable(torch::kCPU);
  torch::manual_seed(40);
  ppo.update(noisy_rollout(m, T, N, D, A, 0.02), torch::zeros({N}));
  CHECK(ppo.timer().totals().at("host_syncs") == 1);
}

TEST_CASE("bfloat16 autocast holds for its scope and restores the caller's setting",
          "[rl][ppo]") {
  rl::PpoConfig c;
  c.hidden = {16};
  c.obs_norm = false;
  torch::manual_seed(3);
  rl::ActorCritic m(3, 2, c);
  torch::NoGradGuard ng;
  const auto x = torch::randn({8, 3});
  const auto plain = m->mean(x);
  {
    rl::Bf16Autocast on(torch::kCPU, true);
    const auto low = m->mean(x);
    CHECK(low.scalar_type() == torch::kBFloat16);
    CHECK(m->raw_value(x).scalar_type() == torch::kBFloat16);
    // bfloat16 keeps 8 bits of mantissa: near the float32 result, not equal to it
    const double err = (low.to(torch::kFloat32) - plain).abs().max().item<double>();
    CHECK(err > 0);
    CHECK(err < 0.02 * plain.abs().max().item<double>() + 1e-3);
    {
      rl::Bf16Autocast off(torch::kCPU, false);  // off: leaves the outer scope's setting
      CHECK(m->mean(x).scalar_type() == torch::kBFloat16);
    }
  }
  CHECK(m->mean(x).scalar_type() == torch::kFloat32);
  CHECK(torch::equal(m->mean(x), plain));
}

// One update of each of two PPOs on the same rollout of `m` (seed 5) and last values, each
// from the same random state (seed 6): what two settings of one update do differently.
std::pair<rl::UpdateStats, rl::UpdateStats> twin_updates(rl::Ppo& a, rl::Ppo& b, rl::ActorCritic& m,
                                                         int64_t T, int64_t N, int64_t D,
                                                         int64_t A) {
  torch::manual_seed(5);
  const auto r = noisy_rollout(m, T, N, D, A, 0.1);
  const auto last = torch::randn({N});
  torch::manual_seed(6);
  auto sa = a.update(r, last);
  torch::manual_seed(6);
  return {sa, b.update(r, last)};
}

// How far `ref`'s update moved its parameters from `before`, and how far `other`'s update ended
// from `ref`'s: the two 2-norms over all parameters.
struct StepGap {
  double step, gap;
};
StepGap step_and_gap(const std::vector<torch::Tensor>& before, rl::ActorCritic& ref,
                     rl::ActorCritic& other) {
  double step = 0, gap = 0;
  const auto pr = ref->parameters(), po = other->parameters();
  for (size_t k = 0; k < pr.size(); ++k) {
    step += (pr[k] - before[k]).pow(2).sum().item<double>();
    gap += (po[k] - pr[k]).pow(2).sum().item<double>();
  }
  return {std::sqrt(step), std::sqrt(gap)};
}

// A small network's update: two epochs of two minibatches at a fixed learning rate of 1e-3.
rl::PpoConfig small_update_config() {
  rl::PpoConfig c;
  c.hidden = {64, 64};
  c.epochs = 2;
  c.minibatches = 2;
  c.schedule = "fixed";
  c.lr = 1e-3;
  return c;
}

TEST_CASE("PPO's bfloat16 update stays near its float32 update and learns the bandit",
          "[rl][ppo]") {
  rl::PpoConfig c = small_update_config();
  c.obs_norm = false;
  const int64_t T = 4, N = 64, D = 3, A = 2;
  torch::manual_seed(17);
  rl::ActorCritic full(D, A, c);
  torch::manual_seed(17);
  rl::ActorCritic low(D, A, c);
  const auto before = test::param_copies(*full);
  rl::PpoConfig cb = c;
  cb.bf16 = true;
  rl::Ppo ppo_full(full, c), ppo_low(low, cb);
  const auto [st_full, st_low] = twin_updates(ppo_full, ppo_low, full, T, N, D, A);
  // parameters stay float32; the step differs by rounding, a small part of the step itself
  for (const auto& p : low->parameters()) CHECK(p.scalar_type() == torch::kFloat32);
  const auto [step, gap] = step_and_gap(before, full, low);
  INFO("step " << step << ", gap " << gap);
  CHECK(gap > 0);
  CHECK(gap < 0.25 * step);
  CHECK(st_low.policy_loss == Approx(st_full.policy_loss).margin(0.02));
  CHECK(st_low.value_loss == Approx(st_full.value_loss).epsilon(0.02));
  CHECK(st_low.entropy == Approx(st_full.entropy).epsilon(1e-3));

  // and the one-step bandit is learned in bfloat16 as in float32
  CHECK(bandit_gain(true) > 0.3);
}

TEST_CASE("PPO with align_widths pads odd widths with zeros and gives the plain update",
          "[rl][ppo]") {
  const rl::PpoConfig c = small_update_config();
  const int64_t T = 4, N = 64, D = 5, A = 3;  // the observation's, action's and value's widths odd
  rl::PpoConfig ca = c;
  ca.align_widths = true;
  torch::manual_seed(23);
  rl::ActorCritic plain(D, A, c);
  torch::manual_seed(23);
  rl::ActorCritic padded(D, A, ca);
  // the same named parameters; the first and last layers padded to multiples of 8
  const auto pp = plain->named_parameters(), pa = padded->named_parameters();
  REQUIRE(pp.size() == pa.size());
  CHECK(pa["actor.0.weight"].sizes() == torch::IntArrayRef({64, 8}));
  CHECK(pa["actor.4.weight"].sizes() == torch::IntArrayRef({8, 64}));
  CHECK(pa["actor.4.bias"].sizes() == torch::IntArrayRef({8}));
  CHECK(pa["critic.4.weight"].sizes() == torch::IntArrayRef({8, 64}));
  CHECK(pa["actor.2.weight"].sizes() == torch::IntArrayRef({64, 64}));  // 64: left as it is
  // the plain parameters sit in the padded ones' corner, zeros around them
  auto corner = [](const torch::Tensor& p, const torch::Tensor& like) {
    auto x = p;
    for (int64_t d = 0; d < like.dim(); ++d) x = x.narrow(d, 0, like.size(d));
    return x;
  };
  auto rest = [&](const torch::Tensor& p, const torch::Tensor& like) {  // |entries| outside it
    auto q = p.detach().clone();
    corner(q, like).zero_();
    return q.abs().sum().item<double>();
  };
  for (const auto& kv : pp) {
    INFO(kv.key());
    CHECK(torch::equal(corner(pa[kv.key()], kv.value()), kv.value()));
    CHECK(rest(pa[kv.key()], kv.value()) == 0.0);
  }
  // the same outputs
  torch::manual_seed(4);
  const auto obs = torch::randn({N, D});
  CHECK(torch::allclose(padded->mean(obs), plain->mean(obs), 1e-6, 1e-6));
  CHECK(torch::allclose(padded->value(obs), plain->value(obs), 1e-6, 1e-6));
  CHECK(padded->mean(obs).sizes() == torch::IntArrayRef({N, A}));
  // the same update, within float tolerance, and the padding still zero after it
  rl::Ppo ppo_plain(plain, c), ppo_padded(padded, ca);
  const auto [st_plain, st_padded] = twin_updates(ppo_plain, ppo_padded, plain, T, N, D, A);
  CHECK(st_padded.policy_loss == Approx(st_plain.policy_loss).margin(1e-5));
  CHECK(st_padded.value_loss == Approx(st_plain.value_loss).epsilon(1e-5));
  double moved = 0;
  for (const auto& kv : pp) {
    INFO(kv.key());
    CHECK(torch::allclose(corner(pa[kv.key()], kv.value()), kv.value(), 1e-5, 1e-6));
    CHECK(rest(pa[kv.key()], kv.value()) == 0.0);
    moved += kv.value().abs().sum().item<double>();
  }
  CHECK(moved > 0);
}

TEST_CASE("grouped running norms keep each group's moments apart", "[rl][ppo]") {
  torch::manual_seed(9);
  rl::RunningNorm grouped(3, 1e9, true), g0(1, 1e9), g2(1, 1e9);
  for (int k = 0; k < 3; ++k) {  // three batches; group 1 never appears
    const auto groups = torch::tensor({0, 2, 0, 2, 2, 0, 0}, torch::kLong);
    const auto x = torch::randn({7}) * (k + 1) + 10 * groups.to(torch::kFloat32);
    grouped->update(x, groups);
    g0->update(x.index({groups == 0}).unsqueeze(1));
    g2->update(x.index({groups == 2}).unsqueeze(1));
  }
  // the same moments as a normaliser that saw only that group's rows
  const auto probe = torch::tensor({1.5f, -2.f, 30.f});
  const auto on0 = grouped->normalize(probe, torch::zeros({3}, torch::kLong));
  const auto on2 = grouped->normalize(probe, torch::full({3}, 2, torch::kLong));
  CHECK(torch::allclose(on0, g0->normalize(probe.unsqueeze(1)).squeeze(1), 1e-5, 1e-5));
  CHECK(torch::allclose(on2, g2->normalize(probe.unsqueeze(1)).squeeze(1), 1e-5, 1e-5));
  // an unseen group keeps its start (mean 0, variance 1); denormalize inverts normalize
  const auto on1 = grouped->normalize(probe, torch::ones({3}, torch::kLong));
  CHECK(torch::allclose(on1, probe, 1e-4, 1e-4));
  const auto mixed = torch::tensor({0, 1, 2}, torch::kLong);
  CHECK(torch::allclose(grouped->denormalize(grouped->normalize(probe, mixed), mixed), probe,
                        1e-5, 1e-4));
  CHECK(grouped->count() == Approx(21).margin(1e-3));
  // undefined groups: a one-dimensional normaliser on scalars, as before
  rl::RunningNorm one(1, 1e9), ref(1, 1e9);
  const auto x = torch::randn({5});
  one->update(x, torch::Tensor());
  ref->update(x.unsqueeze(1));
  CHECK(torch::allclose(one->normalize(x, torch::Tensor()),
                        ref->normalize(x.unsqueeze(1)).squeeze(1)));
}

TEST_CASE("PPO with value_norm per task normalises each task's returns by its own moments",
          "[rl][ppo]") {
  // two tasks, one-hot ids ending the observation; task 1's rewards are 100 times task 0's
  rl::PpoConfig c;
  c.hidden = {16};
  c.epochs = 1;
  c.minibatches = 2;
  c.obs_norm = false;
  c.value_norm = c.value_norm_task = true;
  const int64_t T = 4, N = 16, D = 4, A = 2, ntasks = 2;
  torch::manual_seed(12);
  rl::ActorCritic m(D, A, c, ntasks);
  rl::Ppo ppo(m, c, ntasks);
  rl::Rollout r(T, N, D, A, torch::Device(torch::kCPU));
  torch::NoGradGuard ng;
  auto task = (torch::arange(N) % 2).to(torch::kLong);  // slot s runs task s % 2
  auto obs = torch::randn({T, N, D});
  obs.narrow(2, D - ntasks, ntasks).copy_(
      torch::one_hot(task, ntasks).to(torch::kFloat32).expand({T, N, ntasks}));
  r.nobs.copy_(obs);
  r.log_std.copy_(m->log_std());
  auto mu = m->mean(obs);
  auto a = mu + torch::exp(r.log_std) * torch::randn({T, N, A});
  r.actions.copy_(a);
  r.mu.copy_(mu);
  r.values.copy_(m->value(obs));
  r.logp.copy_(rl::gaussian_log_prob(a, mu, r.log_std));
  r.rewards.copy_(torch::rand({T, N}) * torch::where(task == 1, 100.0, 1.0));
  const auto last = m->value(obs[T - 1]);
  torch::GradMode::set_enabled(true);
  ppo.update(r, last);
  torch::GradMode::set_enabled(false);
  // the returns the update saw: GAE's targets, by task
  const auto ret = rl::gae(r.rewards, r.values, r.dones, last, c.gamma, c.lambda).second;
  for (int64_t k = 0; k < ntasks; ++k) {
    const auto rows = ret.index({torch::indexing::Slice(), task == k}).reshape({-1});
    rl::RunningNorm want(1, 1e9);
    want->update(rows.unsqueeze(1));
    const auto probe = torch::tensor({0.f, 50.f});
    const auto ids = torch::full({2}, k, torch::kLong);
    INFO("task " << k);
    CHECK(torch::allclose(m->value_norm()->normalize(probe, ids),
                          want->normalize(probe.unsqueeze(1)).squeeze(1), 1e-4, 1e-4));
  }
  // and the critic's values come back in each task's own units
  const auto raw = m->raw_value(obs[0]);
  CHECK(torch::allclose(m->value(obs[0]), m->value_norm()->denormalize(raw, task)));
  CHECK(torch::equal(m->value_groups(obs[0]), task));
}

TEST_CASE("a PPO run saved and loaded continues as the unbroken run", "[rl][ppo]") {
  rl::TrainConfig tc;
  tc.ppo.hidden = {16};
  tc.ppo.horizon = 4;
  tc.ppo.epochs = 2;
  tc.ppo.minibatches = 2;
  const int64_t N = 8, D = 3, A = 2;
  auto make = [&](uint64_t seed) {
    torch::manual_seed(seed);
    return rl::make_algorithm("ppo", tc, D, A, N, torch::kCPU);
  };
  auto run_update = [&](rl::Algorithm& alg, uint64_t seed) {
    torch::manual_seed(seed);
    for (int t = 0; t < alg.steps_per_update(); ++t) {
      alg.act(torch::randn({N, D}));
      rl::Transition tr;
      tr.obs = torch::randn({N, D});
      tr.reward = torch::randn({N});
      tr.done = (torch::rand({N}) < 0.2).to(torch::kFloat32);
      tr.final_ids = torch::empty({0}, torch::kLong);
      tr.final_obs = torch::empty({0, D});
      alg.observe(tr);
    }
    return alg.update(torch::randn({N, D}));
  };
  auto a = make(1);
  run_update(*a, 10);
  run_update(*a, 11);
  torch::serialize::OutputArchive out;
  a->save(out);
  std::ostringstream bytes;
  out.save_to(bytes);
  auto b = make(2);
  {
    torch::serialize::InputArchive in;
    std::istringstream is(bytes.str());
    in.load_from(is);
    b->load(in, "memory");
  }
  for (uint64_t seed : {12, 13}) {
    const auto ma = run_update(*a, seed), mb = run_update(*b, seed);
    CHECK(ma == mb);
  }
  torch::manual_seed(14);
  const auto obs = torch::randn({N, D});
  CHECK(torch::equal(a->actor(obs), b->actor(obs)));
}

// rl::linear_gemm_bias_grad against LibTorch's linear: the same output and gradients (the bias's
// a product with a row of ones instead of a sum over the rows), for inputs of any leading shape,
// with and without the input's gradient, and under bfloat16 autocast in autocast's types.
TEST_CASE("linear_gemm_bias_grad gives linear's output and gradients", "[rl][ppo]") {
  torch::manual_seed(31);
  const auto w0 = torch::randn({6, 5}), b0 = torch::randn({6});
  const auto x0 = torch::randn({3, 7, 5});
  auto run = [&](bool gemm, bool x_grad) {
    auto w = w0.clone().requires_grad_(true), b = b0.clone().requires_grad_(true);
    auto x = x0.clone().requires_grad_(x_grad);
    auto y = gemm ? rl::linear_gemm_bias_grad(x, w, b) : torch::nn::functional::linear(x, w, b);
    // a loss whose gradient differs from row to row
    (y * torch::arange(y.numel()).reshape(y.sizes()).sin()).sum().backward();
    return std::vector<torch::Tensor>{y.detach(), w.grad(), b.grad(), x.grad()};
  };
  for (bool x_grad : {true, false}) {
    INFO("input gradient " << x_grad);
    const auto want = run(false, x_grad), got = run(true, x_grad);
    CHECK(got[0].sizes() == torch::IntArrayRef({3, 7, 6}));
    for (int k = 0; k < 3; ++k) CHECK(torch::allclose(got[k], want[k], 1e-5, 1e-5));
    CHECK(got[3].defined() == x_grad);
    if (x_grad) CHECK(torch::allclose(got[3], want[3], 1e-5, 1e-5));
    CHECK(got[2].abs().sum().item<double>() > 1);  // the bias gradient is not trivially zero
  }
  // under bfloat16 autocast: a bfloat16 output, float32 gradients, near linear's in autocast
  auto run_bf16 = [&](bool gemm) {
    auto w = w0.clone().requires_grad_(true), b = b0.clone().requires_grad_(true);
    auto x = x0.clone().requires_grad_(true);
    torch::Tensor y;
    {
      rl::Bf16Autocast bf16(torch::kCPU, true);
      y = gemm ? rl::linear_gemm_bias_grad(x, w, b) : torch::nn::functional::linear(x, w, b);
    }
    (y.to(torch::kFloat32) * torch::arange(y.numel()).reshape(y.sizes()).sin()).sum().backward();
    return std::vector<torch::Tensor>{y.detach(), w.grad(), b.grad(), x.grad()};
  };
  const auto want = run_bf16(false), got = run_bf16(true);
  CHECK(got[0].scalar_type() == torch::kBFloat16);
  for (int k = 1; k < 4; ++k) CHECK(got[k].scalar_type() == torch::kFloat32);
  for (int k = 0; k < 4; ++k)
    CHECK(torch::allclose(got[k].to(torch::kFloat32), want[k].to(torch::kFloat32), 2e-2, 5e-2));
}

// Under a live FlatAdam::CopyScope whose optimiser keeps a bfloat16 copy, the layer's bfloat16
// products read the weight and bias from that copy: the same output and gradients, bit for bit,
// as casting them; and a copy left stale on purpose shows that it is the copy that is read.
TEST_CASE("linear_gemm_bias_grad reads its bfloat16 weights from the optimiser's copy",
          "[rl][ppo]") {
  torch::manual_seed(37);
  auto w = torch::randn({6, 5}).requires_grad_(true), b = torch::randn({6}).requires_grad_(true);
  const auto x = torch::randn({4, 5});
  rl::FlatAdam opt({w, b}, 1e-3);
  opt.keep_copy(torch::kBFloat16);
  auto run = [&](bool scoped) {
    std::unique_ptr<rl::FlatAdam::CopyScope> scope;
    if (scoped) scope = std::make_unique<rl::FlatAdam::CopyScope>(opt);
    opt.zero_grad();
    torch::Tensor y;
    {
      rl::Bf16Autocast bf16(torch::kCPU, true);
      y = rl::linear_gemm_bias_grad(x, w, b);
    }
    (y.to(torch::kFloat32) * torch::arange(y.numel()).reshape(y.sizes()).cos()).sum().backward();
    return std::vector<torch::Tensor>{y.detach(), w.grad().clone(), b.grad().clone()};
  };
  const auto cast = run(false), copied = run(true);
  for (int k = 0; k < 3; ++k) CHECK(torch::equal(copied[k], cast[k]));
  {  // the weights written in place, the copy not refreshed
    torch::NoGradGuard ng;
    w.add_(1.0);
    b.add_(1.0);
  }
  const auto stale = run(true), fresh = run(false);
  CHECK(torch::equal(stale[0], cast[0]));  // the copy's weights, as before the write
  CHECK_FALSE(torch::equal(fresh[0], cast[0]));
  opt.refresh_copy();
  CHECK(torch::equal(run(true)[0], fresh[0]));
}

// On a CUDA device (where LibTorch has mm's out_dtype, 2.8 on) the bfloat16 layer's weight and
// bias gradients are the products' float32 sums, not sums rounded to bfloat16 and cast: within
// float32 rounding of the same product taken in float32 from the same bfloat16 factors. CPU
// builds and older LibTorch round, so there the test only warns.
TEST_CASE("linear_gemm_bias_grad's bfloat16 gradients are float32 sums on CUDA", "[rl][ppo]") {
  if (!torch::cuda::is_available()) {
    WARN("no CUDA device: the float32 products of the gradients are not checked");
    return;
  }
  const auto dev = torch::Device(torch::kCUDA);
  torch::manual_seed(43);
  auto w = torch::randn({256, 96}, dev).requires_grad_(true);
  auto b = torch::randn({256}, dev).requires_grad_(true);
  const auto x = torch::randn({512, 96}, dev);
  const auto g = torch::randn({512, 256}, dev).to(torch::kBFloat16);
  torch::Tensor y;
  {
    rl::Bf16Autocast bf16(torch::kCUDA, true);
    y = rl::linear_gemm_bias_grad(x, w, b);
  }
  y.backward(g);
  const auto xf = x.to(torch::kBFloat16).to(torch::kFloat32), gf = g.to(torch::kFloat32);
  const auto dw = gf.t().mm(xf), db = gf.sum(0);
  auto rel = [](const torch::Tensor& a, const torch::Tensor& want) {
    return ((a - want).abs().max() / want.abs().max()).item<double>();
  };
  INFO("weight " << rel(w.grad(), dw) << ", bias " << rel(b.grad(), db));
  CHECK(w.grad().scalar_type() == torch::kFloat32);
  CHECK(rel(w.grad(), dw) < 2e-4);  // bfloat16's rounding alone is about 4e-3
  CHECK(rel(b.grad(), db) < 2e-4);
}

// PaddedLinear and the actor-critic take observations already padded to input_width() with
// zero columns, giving the unpadded input's outputs and gradients.
TEST_CASE("the actor-critic takes observations padded to its input width", "[rl][ppo]") {
  const int64_t D = 5, A = 3;
  for (bool align : {false, true}) {
    INFO("align_widths " << align);
    rl::PpoConfig c;
    c.hidden = {16};
    c.align_widths = align;
    c.bias_grad_gemm = true;
    torch::manual_seed(47);
    rl::ActorCritic m(D, A, c);
    CHECK(m->input_width() == (align ? 8 : D));
    torch::manual_seed(48);
    const auto x = torch::randn({7, D});
    const auto xp = torch::constant_pad_nd(x, {0, m->input_width() - D});
    auto grads = [&](const torch::Tensor& in) {
      for (auto& p : m->parameters()) p.mutable_grad() = torch::Tensor();
      auto mu = m->mean(in), v = m->raw_value(in);
      (mu.sum() + v.sum()).backward();
      std::vector<torch::Tensor> out{mu.detach(), v.detach()};
      for (const auto& p : m->parameters())
        if (p.grad().defined()) out.push_back(p.grad().clone());
      return out;
    };
    const auto want = grads(x), got = grads(xp);
    REQUIRE(got.size() == want.size());
    for (size_t k = 0; k < got.size(); ++k) CHECK(torch::equal(got[k], want[k]));
  }
}

// (fused_adam too: FlatAdam's fused step where this LibTorch has it, tests/rl/flat_adam_test.cc)
TEST_CASE("PPO with bias_grad_gemm and fused_adam gives the plain update, padded or not",
          "[rl][ppo]") {
  const int64_t T = 4, N = 64, D = 5, A = 3;
  for (bool align : {false, true}) {
    INFO("align_widths " << align);
    rl::PpoConfig c = small_update_config();
    c.align_widths = align;
    rl::PpoConfig cg = c;
    cg.bias_grad_gemm = true;
    cg.fused_adam = true;
    torch::manual_seed(29);
    rl::ActorCritic plain(D, A, c);
    torch::manual_seed(29);
    rl::ActorCritic gemm(D, A, cg);
    // the same parameters by name; every layer now takes the matrix-product bias gradient
    const auto pp = plain->named_parameters(), pg = gemm->named_parameters();
    REQUIRE(pp.size() == pg.size());
    for (const auto& kv : pp) CHECK(torch::equal(pg[kv.key()], kv.value()));
    for (const auto& m : gemm->modules(false))
      CHECK_FALSE(dynamic_cast<torch::nn::LinearImpl*>(m.get()));
    const auto before = test::param_copies(*plain);
    rl::Ppo ppo_plain(plain, c), ppo_gemm(gemm, cg);
    const auto [st_plain, st_gemm] = twin_updates(ppo_plain, ppo_gemm, plain, T, N, D, A);
    CHECK(st_gemm.policy_loss == Approx(st_plain.policy_loss).margin(1e-5));
    CHECK(st_gemm.value_loss == Approx(st_plain.value_loss).epsilon(1e-5));
    double moved = 0;
    const auto pl = plain->parameters();
    for (const auto& kv : pp) {
      INFO(kv.key());
      CHECK(torch::allclose(pg[kv.key()], kv.value(), 1e-5, 1e-6));
    }
    for (size_t k = 0; k < pl.size(); ++k) moved += (pl[k] - before[k]).abs().sum().item<double>();
    CHECK(moved > 1e-2);
  }
}

// ppo.bf16 with bias_grad_gemm: the minibatches read their weights from the optimiser's bfloat16
// copy and their rows from one bfloat16 cast of the update's observations, padded. The update is
// the one whose layers cast their own weights and rows (bias_grad_gemm off) up to the bias
// gradient's summation order, far inside the step itself.
TEST_CASE("PPO's bfloat16 update from the weights' copy gives the update of per-layer casts",
          "[rl][ppo]") {
  const int64_t T = 4, N = 64, D = 5, A = 3;
  for (bool align : {false, true}) {
    INFO("align_widths " << align);
    rl::PpoConfig c = small_update_config();
    c.bf16 = true;
    c.align_widths = align;
    rl::PpoConfig cg = c;
    cg.bias_grad_gemm = true;
    torch::manual_seed(53);
    rl::ActorCritic plain(D, A, c);
    torch::manual_seed(53);
    rl::ActorCritic gemm(D, A, cg);
    rl::Ppo ppo_plain(plain, c), ppo_gemm(gemm, cg);
    {  // both networks' weights written in place after the optimisers were made (as a load
       // into them would): the update reads them as they are now
      torch::NoGradGuard ng;
      for (auto* m : {&plain, &gemm})
        for (auto& p : (*m)->parameters()) p.mul_(1.5);
    }
    const auto before = test::param_copies(*plain);
    const auto w0 = gemm->parameters()[0];
    CHECK(ppo_gemm.optimizer().copy_of(w0, torch::kBFloat16).defined());
    CHECK_FALSE(ppo_plain.optimizer().copy_of(plain->parameters()[0], torch::kBFloat16).defined());
    const auto [st_plain, st_gemm] = twin_updates(ppo_plain, ppo_gemm, plain, T, N, D, A);
    CHECK(st_gemm.policy_loss == Approx(st_plain.policy_loss).margin(1e-3));
    CHECK(st_gemm.value_loss == Approx(st_plain.value_loss).epsilon(1e-3));
    const auto [step, gap] = step_and_gap(before, plain, gemm);
    INFO("step " << step << ", gap " << gap);
    CHECK(step > 1e-2);
    CHECK(gap < 0.02 * step);  // about 0.002; a stale copy: 0.35
    // the copy is the weights after the last step
    CHECK(torch::equal(ppo_gemm.optimizer().copy_of(w0, torch::kBFloat16),
                       w0.to(torch::kBFloat16)));
  }
}

namespace {

// GaussianOnPolicy's acting and recording alone, its rollout and bootstrap open to the test.
class ActProbe : public rl::GaussianOnPolicy {
 public:
  using GaussianOnPolicy::GaussianOnPolicy;
  std::vector<double> update(const torch::Tensor&) override { return {}; }
  const std::vector<std::string>& metric_names() const override {
    static const std::vector<std::string> none;
    return none;
  }
  void save(torch::serialize::OutputArchive&) override {}
  void load(torch::serialize::InputArchive&, const std::string&) override {}
  rl::ActorCritic& model() { return model_; }
  rl::Rollout& rollout() { return *ro_; }
  torch::Tensor finish(const torch::Tensor& obs) { return finish_rollout(obs); }
};

}  // namespace

// ppo.bf16_act: the rollout's actor and critic run their products in bfloat16 (acting, the
// bootstrap of cut episodes and of the rollout's end) and the rows stay float32. Each recorded
// row equals the networks' output computed by hand under bfloat16 autocast, and differs from
// float32's by rounding only; with the setting off, the rows are float32's.
TEST_CASE("PPO's act step in bfloat16 records float32 rows of bfloat16 products", "[rl][ppo]") {
  const int64_t N = 64, D = 5, A = 3, K = 8;
  for (bool low : {false, true}) {
    INFO("bf16_act " << low);
    rl::PpoConfig c;
    c.hidden = {32, 32};
    c.horizon = 2;
    c.value_norm = true;
    c.bf16_act = low;
    torch::manual_seed(41);
    ActProbe probe(c, D, A, N, torch::kCPU);
    auto& m = probe.model();
    // the value normaliser away from (0, 1), so that its denormalising shows in the values
    m->value_norm()->update(40.0 * torch::randn({256, 1}) + 30.0);
    torch::manual_seed(42);
    const auto obs = 3.0 * torch::randn({N, D}) + 1.0, final_obs = torch::randn({K, D}),
               end_obs = torch::randn({N, D}), reward = torch::randn({N});
    torch::manual_seed(7);
    const auto a = probe.act(obs);
    // by hand: the normaliser has seen obs; the same noise
    torch::NoGradGuard ng;
    const auto nobs = m->normalize_obs(obs);
    // the actor's mean, and the critic's value of raw observations, with products in bfloat16
    auto mean_of = [&](bool bf16) {
      rl::Bf16Autocast scope(torch::kCPU, bf16);
      return m->mean(nobs).to(torch::kFloat32);
    };
    auto value_of = [&](const torch::Tensor& x, bool bf16) {
      rl::Bf16Autocast scope(torch::kCPU, bf16);
      return m->value(m->normalize_obs(x));
    };
    const auto mu = mean_of(low), v = value_of(obs, low);
    torch::manual_seed(7);
    const auto want_a = mu + torch::exp(m->log_std()) * torch::randn_like(mu);
    auto& ro = probe.rollout();
    for (const auto& row : {ro.mu[0], ro.values[0], ro.actions[0], ro.logp[0]})
      CHECK(row.scalar_type() == torch::kFloat32);
    CHECK(torch::allclose(ro.mu[0], mu, 1e-6, 1e-7));
    CHECK(torch::allclose(ro.values[0], v, 1e-6, 1e-5));
    CHECK(torch::allclose(a, want_a, 1e-6, 1e-7));
    CHECK(torch::allclose(ro.logp[0], rl::gaussian_log_prob(want_a, mu, m->log_std()), 1e-6,
                          1e-5));
    // bfloat16's rounding, or none: the float32 products' distance from the rows
    const auto mu32 = mean_of(false), v32 = value_of(obs, false);
    const double mu_gap = (ro.mu[0] - mu32).abs().max().item<double>();
    const double v_gap = (ro.values[0] - v32).abs().max().item<double>();
    INFO("mean's gap " << mu_gap << ", value's gap " << v_gap);
    if (low) {
      CHECK(mu_gap > 0);
      CHECK(mu_gap < 0.01);  // the output layer's small gain keeps the mean small
      CHECK(v_gap > 0);
      CHECK(v_gap < 0.02 * v32.abs().max().item<double>());
    } else {
      CHECK(mu_gap == 0);
      CHECK(v_gap == 0);
    }
    // a cut episode's reward is bootstrapped from the value as the rollout computes it
    rl::Transition tr;
    tr.obs = end_obs;
    tr.reward = reward;
    tr.done = torch::zeros({N});
    tr.final_ids = torch::arange(K);
    tr.final_obs = final_obs;
    probe.observe(tr);
    const auto vf = value_of(final_obs, low), vf32 = value_of(final_obs, false);
    const auto want_r = reward.clone().narrow(0, 0, K).add(c.gamma * vf);
    CHECK(torch::allclose(ro.rewards[0].narrow(0, 0, K), want_r, 1e-6, 1e-5));
    CHECK(torch::equal(ro.rewards[0].narrow(0, K, N - K), reward.narrow(0, K, N - K)));
    // and the value after the rollout
    const auto vend = value_of(end_obs, low);
    const auto end = probe.finish(end_obs);
    CHECK(end.scalar_type() == torch::kFloat32);
    CHECK(torch::allclose(end, vend, 1e-6, 1e-5));
    const double boot_gap = (ro.rewards[0].narrow(0, 0, K) - (reward.narrow(0, 0, K) +
                                                              c.gamma * vf32)).abs().max()
                                .item<double>();
    const double end_gap = (end - value_of(end_obs, false)).abs().max().item<double>();
    INFO("bootstrap's gap " << boot_gap << ", end value's gap " << end_gap);
    CHECK((low ? boot_gap > 0 : boot_gap == 0));
    CHECK((low ? end_gap > 0 : end_gap == 0));
  }
}
