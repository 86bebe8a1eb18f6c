// metarl/rl2: RL^2's learner keeps each slot's memory through the episodes of a trial and clears
// it only where the next trial starts; its PPO update learns a simple rewarded action; its
// input normalisation and per-task reward scale.
// LibTorch first: Debian's LibTorch pulls in glog, whose CHECK macro would replace Catch's
#include <torch/torch.h>
#undef CHECK

#include <cmath>
#include <sstream>

#include <catch2/catch.hpp>

#include "core/yaml.h"
#include "metarl/config.h"
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

TEST_CASE("RL^2's input_norm: normalised observations and symlog rewards, kept by the policy",
          "[metarl][rl2]") {
  torch::manual_seed(7);
  auto c = small();
  c.input_norm = true;
  metarl::Rl2 rl2(3, 2, 64, c, torch::Device(torch::kCPU));
  REQUIRE(rl2.policy()->input_norm());
  // observations far from zero, of different scales per dimension
  const auto scale = torch::tensor({1.f, 100.f, 0.01f});
  const auto offset = torch::tensor({50.f, -300.f, 2.f});
  for (int t = 0; t < 4; ++t) {
    rl2.act(torch::randn({64, 3}) * scale + offset);
    rl2.observe(torch::zeros({64}), torch::zeros({64}));
  }
  const auto obs = torch::randn({64, 3}) * scale + offset;
  const auto r = torch::tensor({std::exp(1.f) - 1, -(std::exp(2.f) - 1)}).repeat({32});
  torch::NoGradGuard ng;
  const auto in = rl2.policy()->input(obs, torch::zeros({64, 2}), r, torch::zeros({64}));
  REQUIRE(in.size(1) == 3 + 2 + 2);
  const auto o = in.slice(1, 0, 3);
  CHECK(o.mean(0).abs().max().item<float>() < 0.5);
  CHECK(o.std(0).sub(1).abs().max().item<float>() < 0.3);
  // symlog: e - 1 -> 1, -(e^2 - 1) -> -2
  CHECK(in[0][5].item<float>() == Approx(1.0).margin(1e-5));
  CHECK(in[1][5].item<float>() == Approx(-2.0).margin(1e-5));
  // the statistics are the module's: a copy made from its saved state reads the same rows
  std::stringstream buf;
  torch::save(rl2.policy(), buf);
  metarl::RecurrentPolicy copy(3, 2, 8, 0.8, true);
  torch::load(copy, buf);
  CHECK(torch::allclose(copy->input(obs, torch::zeros({64, 2}), r, torch::zeros({64})), in));
  // without input_norm the row is the raw rl2_input
  metarl::RecurrentPolicy raw(3, 2, 8, 0.8);
  CHECK_FALSE(raw->input_norm());
  CHECK(torch::equal(raw->input(obs, torch::zeros({64, 2}), r, torch::zeros({64})),
                     metarl::rl2_input(obs, torch::zeros({64, 2}), r, torch::zeros({64}))));
}

TEST_CASE("RL^2's task_reward_norm keeps one return scale per task", "[metarl][rl2]") {
  torch::manual_seed(9);
  auto c = small();
  c.task_reward_norm = true;
  c.gamma = 0.5;
  c.horizon = 8;
  metarl::Rl2 rl2(3, 1, 4, c, torch::Device(torch::kCPU));
  // slots 0 and 2 do task 0 (reward 1000 per step), slots 1 and 3 task 1 (reward 0.001);
  // episodes of 4 steps
  rl2.set_slot_tasks({0, 1, 0, 1}, 2);
  const auto obs = torch::zeros({4, 3});
  const auto reward = torch::tensor({1000.f, 0.001f, 1000.f, 0.001f});
  for (int t = 0; t < 8; ++t) {
    rl2.act(obs);
    rl2.observe(reward, torch::full({4}, t % 4 == 3 ? 1.f : 0.f));
  }
  // each task's returns within an episode: r, 1.5 r, 1.75 r, 1.875 r, twice over
  const std::vector<double> g = {1, 1.5, 1.75, 1.875};
  double mean = 0, var = 0;
  for (double x : g) mean += x / 4;
  for (double x : g) var += (x - mean) * (x - mean) / 4;
  const auto s = rl2.reward_scale().stats();
  REQUIRE(s.sizes() == torch::IntArrayRef({3, 2}));
  CHECK(s[0][0].item<double>() == 16);  // 8 steps of 2 slots
  CHECK(s[1][0].item<double>() == Approx(1000 * mean).epsilon(1e-6));
  CHECK(s[1][1].item<double>() == Approx(0.001 * mean).epsilon(1e-4));
  CHECK(s[2][0].item<double>() == Approx(1e6 * var).epsilon(1e-6));
  CHECK(s[2][1].item<double>() == Approx(1e-6 * var).epsilon(1e-3));
  // the update runs on rewards of one scale (the first steps' clipped to 10: each task's
  // returns were all alike then): finite, and the critic's loss stays small (unscaled, task
  // 0's values would be in the thousands)
  const auto m = rl2.update(obs);
  for (double v : m) CHECK(std::isfinite(v));
  INFO("value loss " << m[1]);
  CHECK(m[1] < 100);
  // the statistics go to a checkpoint and come back
  metarl::Rl2 other(3, 1, 4, c, torch::Device(torch::kCPU));
  other.set_slot_tasks({0, 1, 0, 1}, 2);
  {
    std::stringstream buf;
    torch::serialize::OutputArchive out;
    rl2.reward_scale().save(out);
    out.save_to(buf);
    torch::serialize::InputArchive in;
    in.load_from(buf);
    other.reward_scale().load(in);
  }
  CHECK(torch::equal(other.reward_scale().stats(), s));
  CHECK_THROWS_AS(other.reward_scale().set_stats(torch::zeros({3, 5})), std::invalid_argument);
  CHECK_THROWS_AS(other.set_slot_tasks({0, 1}, 2), std::invalid_argument);
}

TEST_CASE("RL^2's section: input_norm and task_reward_norm are optional, off when absent",
          "[metarl][rl2]") {
  const std::string base =
      "hidden_size: 8\ninit_std: 0.8\nhorizon: 4\nepochs: 1\nminibatches: 2\nclip: 0.2\n"
      "lr: 0.001\ngamma: 0.9\nlambda: 0.95\nmax_grad_norm: 1\nentropy_coef: 0\nvalue_coef: 1\n"
      "trial_episodes: 2\n";
  const auto old = metarl::read_rl2(YamlView::load_string(base, "old run"));
  CHECK_FALSE(old.input_norm);
  CHECK_FALSE(old.task_reward_norm);
  const auto now = metarl::read_rl2(
      YamlView::load_string(base + "input_norm: true\ntask_reward_norm: true\n", "new run"));
  CHECK(now.input_norm);
  CHECK(now.task_reward_norm);
  CHECK_THROWS_WITH(
      metarl::read_rl2(YamlView::load_string(base + "input_norm: maybe\n", "bad run")),
      Catch::Contains("input_norm"));
}
