// metarl/rl2: RL^2's learner keeps each slot's memory through the episodes of a trial and clears
// it only where the next trial starts; its PPO update learns a simple rewarded action.
#include <cmath>

#include <catch2/catch.hpp>

#include "metarl/rl2.h"

using namespace bidex;

namespace {
metarl::Rl2Config small() {
  metarl::Rl2Config c;
  c.hidden_size = 8;
  c.horizon = 4;
  c.minibatches = 2;
  c.trial_episodes = 2;
  return c;
}
}  // namespace

TEST_CASE("RL^2 clears a slot's memory when its trial of episodes ends, and only then",
          "[metarl][rl2]") {
  torch::manual_seed(3);
  metarl::Rl2 rl2(3, 2, 2, small(), torch::Device(torch::kCPU));
  const auto obs = torch::randn({2, 3});
  const auto none = torch::zeros({2});
  rl2.act(obs);
  rl2.observe(torch::ones({2}), torch::tensor({1.f, 0.f}));  // slot 0: episode 1 of 2 ends
  CHECK(rl2.trial_ends().equal(torch::zeros({2})));
  rl2.act(obs);
  CHECK(rl2.hidden().abs().sum(2).min().item<float>() > 0);  // both remember
  rl2.observe(torch::ones({2}), torch::tensor({1.f, 0.f}));  // slot 0: episode 2 of 2 ends
  CHECK(rl2.trial_ends().equal(torch::tensor({1.f, 0.f})));
  const auto before = rl2.hidden().clone();
  rl2.act(obs);
  // slot 0 started from no memory and no previous action, reward or done; slot 1 went on
  torch::NoGradGuard ng;
  const auto fresh = metarl::rl2_input(obs, torch::zeros({2, 2}), none, none);
  const auto h0 = std::get<2>(rl2.policy()->forward_step(fresh, torch::zeros({1, 2, 8})));
  CHECK(torch::allclose(rl2.hidden()[0][0], h0[0][0]));
  CHECK_FALSE(torch::allclose(rl2.hidden()[0][1], h0[0][1]));
  CHECK_FALSE(before[0][0].abs().sum().item<float>() == 0);
  CHECK(rl2.trial_ends().equal(torch::zeros({2})));
  rl2.observe(torch::ones({2}), none);
  // the episode count restarted with the trial: one more end is not a trial end
  rl2.act(obs);
  rl2.observe(torch::ones({2}), torch::tensor({1.f, 0.f}));
  CHECK(rl2.trial_ends().equal(torch::zeros({2})));
  // the rollout is full: the update runs and reports finite metrics
  const auto m = rl2.update(obs);
  REQUIRE(m.size() == 4);
  for (double v : m) CHECK(std::isfinite(v));
  CHECK_THROWS_AS(rl2.update(obs), std::logic_error);  // no new rollout yet
}

TEST_CASE("RL^2's PPO update moves the policy towards the rewarded action", "[metarl][rl2]") {
  torch::manual_seed(5);
  auto c = small();
  c.lr = 3e-3;
  c.horizon = 8;
  metarl::Rl2 rl2(3, 1, 16, c, torch::Device(torch::kCPU));
  const auto obs = torch::zeros({16, 3});
  // reward -(a - 0.5)^2, episodes of 4 steps
  double first = 0, last = 0;
  for (int u = 0; u < 30; ++u) {
    double s = 0;
    for (int t = 0; t < c.horizon; ++t) {
      const auto a = rl2.act(obs);
      s += a.mean().item<double>();
      rl2.observe(-(a.squeeze(1).clamp(-1, 1) - 0.5).pow(2),
                  torch::full({16}, (t % 4 == 3) ? 1.f : 0.f));
    }
    if (u == 0) first = s / c.horizon;
    last = s / c.horizon;
    rl2.update(obs);
  }
  INFO("mean action, first rollout " << first << ", last " << last);
  CHECK(last > first + 0.2);
  CHECK(last == Approx(0.5).margin(0.25));
}
