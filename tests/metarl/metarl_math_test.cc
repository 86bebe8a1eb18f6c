// metarl: the functional Gaussian against rl's networks and densities; MAML's inner step against
// a hand-worked policy gradient and, through the step, against finite differences; ProMP's LVC
// objective (value, gradient and the Hessian against the plain and DiCE objectives), the
// clipped surrogate, the KL term and its adaptive coefficient against hand values; RL^2's
// recurrent policy resetting its memory at task boundaries only.
// LibTorch first: Debian's LibTorch pulls in glog, whose CHECK macro would replace Catch's
#include <torch/torch.h>
#undef CHECK

#include <cmath>
#include <functional>
#include <stdexcept>
#include <vector>

#include <catch2/catch.hpp>

#include "metarl/functional_policy.h"
#include "metarl/maml.h"
#include "metarl/promp.h"
#include "metarl/recurrent_policy.h"
#include "rl/policy.h"

using namespace bidex;
using metarl::FunctionalGaussian;
using Params = std::vector<torch::Tensor>;

namespace {

const auto kF64 = torch::TensorOptions().dtype(torch::kFloat64);

torch::Tensor t64(std::vector<double> v) { return torch::tensor(v, kF64); }
torch::Tensor col64(std::vector<double> v) { return t64(std::move(v)).unsqueeze(1); }

// leaves that require grad
Params leaves(Params p) {
  for (auto& t : p) t = t.detach().clone().set_requires_grad(true);
  return p;
}

torch::Tensor flat(const Params& p) {
  std::vector<torch::Tensor> parts;
  for (const auto& t : p) parts.push_back(t.reshape({-1}));
  return torch::cat(parts);
}

double max_abs(const torch::Tensor& t) { return t.abs().max().item<double>(); }

// The linear policy of the hand-worked cases: obs_dim 1, no hidden layer, act_dim 1,
// mean = w x + b, std = exp(s), in double precision.
FunctionalGaussian linear_policy() {
  auto pi = FunctionalGaussian::init(1, {}, 1, "tanh", 1.0, /*seed=*/0);
  pi.to(kF64);
  return pi;
}
Params linear_params(double w, double b, double s) {
  return leaves({t64({w}).reshape({1, 1}), t64({b}), t64({s})});
}

// The Hessian [n, n] of a scalar function of the parameters (flattened in list order).
torch::Tensor hessian(const std::function<torch::Tensor(const Params&)>& f, const Params& p) {
  const auto g = flat(torch::autograd::grad({f(p)}, p, {}, /*retain_graph=*/true,
                                            /*create_graph=*/true));
  std::vector<torch::Tensor> rows;
  for (int64_t i = 0; i < g.size(0); ++i) {
    auto gi = torch::autograd::grad({g[i]}, p, {}, /*retain_graph=*/true, /*create_graph=*/false,
                                    /*allow_unused=*/true);
    for (size_t k = 0; k < gi.size(); ++k)
      if (!gi[k].defined()) gi[k] = torch::zeros_like(p[k]);
    rows.push_back(flat(gi));
  }
  return torch::stack(rows);
}

// The gradient of f by central differences, element by element (double precision).
torch::Tensor finite_difference(const std::function<double(const Params&)>& f, const Params& p,
                                double eps) {
  std::vector<double> out;
  for (size_t k = 0; k < p.size(); ++k) {
    for (int64_t j = 0; j < p[k].numel(); ++j) {
      Params plus, minus;
      for (const auto& t : p) {
        plus.push_back(t.detach().clone());
        minus.push_back(t.detach().clone());
      }
      plus[k].view({-1})[j].add_(eps);
      minus[k].view({-1})[j].sub_(eps);
      out.push_back((f(plus) - f(minus)) / (2 * eps));
    }
  }
  return t64(out);
}

// A small tanh policy in double with parameters spread out (rl::mlp's output gain of 0.01 would
// leave the second-order paths through the hidden layer tiny).
std::pair<FunctionalGaussian, Params> spread_policy(uint64_t seed) {
  auto pi = FunctionalGaussian::init(2, {3}, 2, "tanh", 0.8, seed);
  pi.to(kF64);
  torch::manual_seed(static_cast<int64_t>(seed));
  Params p;
  for (const auto& t : pi.params) p.push_back(0.7 * torch::randn_like(t));
  return {pi, leaves(p)};
}

// The hand-worked batch: three rows (x, a, A) = (1, 1, 2), (2, 0, -1), (-1, 0.5, 0.5).
struct HandBatch {
  torch::Tensor obs = col64({1, 2, -1}), actions = col64({1, 0, 0.5}), adv = t64({2, -1, 0.5});
};

}  // namespace

TEST_CASE("the functional Gaussian is rl::mlp's network with rl's Gaussian density", "[metarl]") {
  torch::manual_seed(1);
  const std::vector<int> hidden = {8, 6};
  const auto obs = torch::randn({5, 4});
  for (const std::string act : {"elu", "relu", "tanh"}) {
    // the parameters in rl::ActorCritic's order and shapes, log_std = log(init_std)
    const auto pi = FunctionalGaussian::init(4, hidden, 3, act, 0.8, /*seed=*/42);
    REQUIRE(pi.params.size() == 7);
    const std::vector<std::vector<int64_t>> shapes = {{8, 4}, {8}, {6, 8}, {6}, {3, 6}, {3}, {3}};
    for (size_t i = 0; i < shapes.size(); ++i) {
      CHECK(pi.params[i].sizes().vec() == shapes[i]);
      CHECK(pi.params[i].requires_grad());
    }
    CHECK(max_abs(pi.params[6] - std::log(0.8)) < 1e-7);
    // the mean is the forward of rl::mlp drawn from the same seed
    torch::manual_seed(42);
    auto net = rl::mlp(4, hidden, 3, act, 0.01);
    CHECK(max_abs(pi.mean(pi.params, obs) - net->forward(obs)) < 1e-6);
    // log-density and entropy are rl's
    const auto a = torch::randn({5, 3});
    CHECK(max_abs(pi.log_prob(pi.params, obs, a) -
                  rl::gaussian_log_prob(a, net->forward(obs), pi.params[6])) < 1e-6);
    CHECK(pi.entropy(pi.params).item<double>() ==
          Approx(3 * (std::log(0.8) + 0.5 + 0.5 * std::log(2 * M_PI))));
  }
  // the seed decides the draw, and the caller's random stream does not move
  torch::manual_seed(5);
  const auto before = torch::rand({4});
  torch::manual_seed(5);
  const auto a = FunctionalGaussian::init(3, {4}, 2, "elu", 1.0, 1);
  const auto b = FunctionalGaussian::init(3, {4}, 2, "elu", 1.0, 1);
  const auto c = FunctionalGaussian::init(3, {4}, 2, "elu", 1.0, 2);
  CHECK(torch::equal(torch::rand({4}), before));
  CHECK(torch::equal(a.params[0], b.params[0]));
  CHECK_FALSE(torch::equal(a.params[0], c.params[0]));
  // bad arguments and parameter lists are refused
  CHECK_THROWS_AS(FunctionalGaussian::init(3, {4}, 2, "gelu", 1.0, 1), std::invalid_argument);
  CHECK_THROWS_AS(FunctionalGaussian::init(3, {4}, 0, "elu", 1.0, 1), std::invalid_argument);
  CHECK_NOTHROW(a.check(c.params));
  CHECK_THROWS_AS(a.check(Params(c.params.begin(), c.params.end() - 1)), std::invalid_argument);
  Params wrong = c.params;
  wrong[0] = torch::zeros({4, 4});
  CHECK_THROWS_AS(a.check(wrong), std::invalid_argument);
}

TEST_CASE("MAML's inner step moves a linear Gaussian by the hand-worked policy gradient",
          "[metarl][maml]") {
  // mean = w x + b, sigma = exp(s) = 2 at w = 0.5, b = 0.25, s = log 2:
  //   log pi = -(a - w x - b)^2 / (2 sigma^2) - s - log(2 pi) / 2, with e = a - w x - b,
  //   d/dw = e x / sigma^2, d/db = e / sigma^2, d/ds = e^2 / sigma^2 - 1.
  // rows (x, a, A) = (1, 1, 2), (2, 0, -1), (-1, 0.5, 0.5): mean 0.75, 1.25, -0.25, so
  //   e = 0.25, -1.25, 0.75 and e^2 / sigma^2 = 0.015625, 0.390625, 0.140625.
  // loss = -mean(log pi A), its gradient -(1/3) sum A d log pi:
  //   dw: sum A e x / 4 = (0.5 + 2.5 - 0.375) / 4 = 0.65625       -> -0.21875
  //   db: sum A e / 4 = (0.5 + 1.25 + 0.375) / 4 = 0.53125        -> -0.1770833...
  //   ds: sum A (e^2/4 - 1) = -1.96875 + 0.609375 - 0.4296875
  //       = -1.7890625                                             -> 0.5963541666...
  // one step of 0.1: w' = 0.521875, b' = 0.2677083..., s' = log 2 - 0.0596354166...
  const auto pi = linear_policy();
  const auto p = linear_params(0.5, 0.25, std::log(2.0));
  const HandBatch h;
  const auto g = torch::autograd::grad({metarl::pg_loss(pi, p, h.obs, h.actions, h.adv)}, p);
  CHECK(g[0].item<double>() == Approx(-0.21875).margin(1e-12));
  CHECK(g[1].item<double>() == Approx(-0.53125 / 3).margin(1e-12));
  CHECK(g[2].item<double>() == Approx(1.7890625 / 3).margin(1e-12));

  const auto q = metarl::inner_step(pi, p, h.obs, h.actions, h.adv, 0.1, false);
  REQUIRE(q.size() == 3);
  CHECK(q[0].item<double>() == Approx(0.521875).margin(1e-12));
  CHECK(q[1].item<double>() == Approx(0.25 + 0.1 * 0.53125 / 3).margin(1e-12));
  CHECK(q[2].item<double>() == Approx(std::log(2.0) - 0.1 * 1.7890625 / 3).margin(1e-12));

  // the same step from parameters that do not require grad (adapting at evaluation)
  const auto q_eval =
      metarl::inner_step(pi, metarl::detached(p), h.obs, h.actions, h.adv, 0.1, false);
  Params plain;
  for (const auto& t : p) plain.push_back(t.detach().clone());
  const auto q_plain = metarl::inner_step(pi, plain, h.obs, h.actions, h.adv, 0.1, false);
  CHECK(max_abs(flat(q_eval) - flat(q)) < 1e-15);
  CHECK(max_abs(flat(q_plain) - flat(q)) < 1e-15);

  // several steps are repeated single steps; zero steps leave the parameters
  const auto q2 = metarl::inner_steps(pi, p, h.obs, h.actions, h.adv, 0.1, 2, true);
  const auto q1q1 = metarl::inner_step(pi, q, h.obs, h.actions, h.adv, 0.1, false);
  CHECK(max_abs(flat(q2) - flat(q1q1)) < 1e-12);
  CHECK(max_abs(flat(metarl::inner_steps(pi, p, h.obs, h.actions, h.adv, 0.1, 0, true)) -
                flat(p)) == 0);
}

TEST_CASE("Meta-SGD's step sizes: per element, the scalar step when all equal, learned through "
          "the step",
          "[metarl][maml]") {
  // the hand-worked gradient of the test above: g = (-0.21875, -0.53125 / 3, 1.7890625 / 3)
  const auto pi = linear_policy();
  const auto p = linear_params(0.5, 0.25, std::log(2.0));
  const HandBatch h;
  const double g[] = {-0.21875, -0.53125 / 3, 1.7890625 / 3};
  // all sizes 0.1: the scalar step, to the last bit
  Params tenth;
  for (const auto& t : p) tenth.push_back(torch::full_like(t, 0.1));
  const auto scalar = metarl::inner_step(pi, p, h.obs, h.actions, h.adv, 0.1, false);
  const auto same = metarl::inner_step(pi, p, h.obs, h.actions, h.adv,
                                       metarl::StepSize(0.1, tenth), false);
  CHECK(max_abs(flat(same) - flat(scalar)) == 0);
  // one size per parameter: each moves by its own
  const double a[] = {0.1, 0.01, 1.0};
  Params alpha;
  for (size_t i = 0; i < p.size(); ++i)
    alpha.push_back(torch::full_like(p[i], a[i]).set_requires_grad(true));
  const auto q = metarl::inner_step(pi, p, h.obs, h.actions, h.adv,
                                    metarl::StepSize(0.1, alpha), false);
  for (size_t i = 0; i < p.size(); ++i) {
    INFO("parameter " << i);
    CHECK(q[i].item<double>() == Approx(p[i].item<double>() - a[i] * g[i]).margin(1e-12));
  }
  // the sizes are in the graph, also first-order: for f = sum(q), df/dalpha_i = -g_i
  const auto dalpha = torch::autograd::grad({q[0] + q[1] + q[2]}, alpha);
  for (size_t i = 0; i < p.size(); ++i) {
    INFO("parameter " << i);
    CHECK(dalpha[i].item<double>() == Approx(-g[i]).margin(1e-12));
  }
  // ProMP's LVC step takes them the same way: with no sampling log-probabilities its gradient
  // is the policy gradient, so it moves by the same steps
  const auto lvc = metarl::lvc_inner_step(pi, p, {h.obs, h.actions, h.adv, {}},
                                          metarl::StepSize(0.1, alpha), false);
  CHECK(max_abs(flat(lvc) - flat(q)) < 1e-12);
  // one size per parameter or none
  CHECK_THROWS_AS(metarl::inner_step(pi, p, h.obs, h.actions, h.adv,
                                     metarl::StepSize(0.1, {alpha[0]}), false),
                  std::invalid_argument);
}

TEST_CASE("MAML's inner step with create_graph carries the second-order term",
          "[metarl][maml]") {
  // the outer loss: the policy-gradient loss on a second batch, of the policy adapted on a first
  const auto sp = spread_policy(3);
  const auto& pi = sp.first;
  const auto& p = sp.second;
  torch::manual_seed(4);
  const auto obs1 = torch::randn({6, 2}, kF64), act1 = torch::randn({6, 2}, kF64);
  const auto adv1 = torch::randn({6}, kF64);
  const auto obs2 = torch::randn({5, 2}, kF64), act2 = torch::randn({5, 2}, kF64);
  const auto adv2 = torch::randn({5}, kF64);
  const double lr = 0.5;
  auto outer = [&](const Params& q, bool create_graph) {
    const auto adapted = metarl::inner_step(pi, q, obs1, act1, adv1, lr, create_graph);
    return metarl::pg_loss(pi, adapted, obs2, act2, adv2);
  };
  const auto exact = flat(torch::autograd::grad({outer(p, true)}, p));
  const auto first_order = flat(torch::autograd::grad({outer(p, false)}, p));
  const auto fd = finite_difference(
      [&](const Params& q) { return outer(q, false).item<double>(); }, p, 1e-6);
  REQUIRE(fd.size(0) == 19);
  // through the step: d outer / d theta = (I - lr H_inner) grad outer(theta'), which central
  // differences reproduce to their truncation error; the first-order gradient drops lr H_inner
  CHECK(max_abs(exact - fd) < 1e-7);
  CHECK(max_abs(first_order - fd) > 1e-3);
  // two steps: still the exact gradient of the composed map
  auto outer2 = [&](const Params& q, bool create_graph) {
    const auto adapted = metarl::inner_steps(pi, q, obs1, act1, adv1, lr, 2, create_graph);
    return metarl::pg_loss(pi, adapted, obs2, act2, adv2);
  };
  const auto exact2 = flat(torch::autograd::grad({outer2(p, true)}, p));
  const auto fd2 = finite_difference(
      [&](const Params& q) { return outer2(q, false).item<double>(); }, p, 1e-6);
  CHECK(max_abs(exact2 - fd2) < 1e-7);
}

TEST_CASE("ProMP's LVC objective: value mean(A), the policy gradient, the low-variance Hessian",
          "[metarl][promp]") {
  const auto pi = linear_policy();
  const auto p = linear_params(0.5, 0.25, std::log(2.0));
  {
    // at the sampling parameters: -J_LVC = -mean(A) = -(2 - 1 + 0.5) / 3, and the gradient is
    // the one worked by hand in the MAML test
    const HandBatch h;
    const metarl::Batch b{h.obs, h.actions, h.adv, {}};
    const auto loss = metarl::lvc_loss(pi, p, b);
    CHECK(loss.item<double>() == Approx(-0.5).margin(1e-12));
    const auto g = torch::autograd::grad({loss}, p);
    CHECK(g[0].item<double>() == Approx(-0.21875).margin(1e-12));
    CHECK(g[1].item<double>() == Approx(-0.53125 / 3).margin(1e-12));
    CHECK(g[2].item<double>() == Approx(1.7890625 / 3).margin(1e-12));
    // its ascent step is MAML's step
    const auto q = metarl::lvc_inner_step(pi, p, b, 0.1, false);
    CHECK(q[0].item<double>() == Approx(0.521875).margin(1e-12));
    CHECK(q[2].item<double>() == Approx(std::log(2.0) - 0.1 * 1.7890625 / 3).margin(1e-12));
    // the sampling policy's log-probabilities give the same value and gradient there, and
    // away from it the importance weight exp(log pi - logp_b)
    const auto logp_b = pi.log_prob(p, h.obs, h.actions).detach();
    const metarl::Batch bb{h.obs, h.actions, h.adv, logp_b};
    CHECK(metarl::lvc_loss(pi, p, bb).item<double>() == Approx(-0.5).margin(1e-12));
    CHECK(max_abs(flat(torch::autograd::grad({metarl::lvc_loss(pi, p, bb)}, p)) - flat(g)) <
          1e-12);
    const auto away = linear_params(0.6, 0.25, std::log(2.0));
    const auto w = torch::exp(pi.log_prob(away, h.obs, h.actions) - logp_b);
    CHECK(metarl::lvc_loss(pi, away, bb).item<double>() ==
          Approx(-(w * h.adv).mean().item<double>()).margin(1e-12));
    CHECK(metarl::lvc_loss(pi, away, b).item<double>() == Approx(-0.5).margin(1e-12));
  }

  // The Hessians, on one trajectory of two steps: (x, a) = (1, 1) then (2, 0), rewards
  // r1 = 1, r2 = 2, so the rewards-to-go are A1 = 3, A2 = 2. With e = a - w x - b and
  // sigma^2 = 4, each step's score g_t and Hessian H_t of log pi are
  //   g = (e x, e, e^2 - sigma^2) / sigma^2
  //   H = [[-x^2, -x, -2 e x], [-x, -1, -2 e], [-2 e x, -2 e, -2 e^2]] / sigma^2
  // (e = 0.25 then -1.25: g1 = (0.0625, 0.0625, -0.984375), g2 = (-0.625, -0.3125, -0.609375)).
  // The three objectives, as means over the two rows, have the same gradient
  // (A1 g1 + A2 g2) / 2 but different Hessians:
  //   plain  mean(log pi A):                (A1 H1 + A2 H2) / 2
  //   LVC    mean(exp(log pi - stop) A):    (A1 (H1 + g1 g1^T) + A2 (H2 + g2 g2^T)) / 2
  //   DiCE   (M(l1) r1 + M(l1 + l2) r2) / 2, M(x) = exp(x - stop(x)):
  //                                          LVC + r2 (g1 g2^T + g2 g1^T) / 2
  // e.g. at (w, w): LVC - plain = (3 x 0.0625^2 + 2 x 0.625^2) / 2 = 0.396484375 and
  // DiCE - LVC = 2 x 2 x 0.0625 x (-0.625) / 2 = -0.078125. DiCE's cross term is the one with
  // high variance; the plain objective's missing g g^T term is MAML's biased curvature.
  const double r1 = 1, r2 = 2, A1 = r1 + r2, A2 = r2;
  const auto obs = col64({1, 2}), actions = col64({1, 0}), adv = t64({A1, A2});
  auto score = [](double x, double a, double w, double b, double s) {
    const double var = std::exp(2 * s), e = a - w * x - b;
    auto g = t64({e * x, e, e * e - var}) / var;
    auto H = t64({-x * x, -x, -2 * e * x, -x, -1, -2 * e, -2 * e * x, -2 * e, -2 * e * e})
                 .reshape({3, 3}) / var;
    return std::make_pair(g, H);
  };
  const auto [g1, H1] = score(1, 1, 0.5, 0.25, std::log(2.0));
  const auto [g2, H2] = score(2, 0, 0.5, 0.25, std::log(2.0));
  CHECK(max_abs(g1 - t64({0.0625, 0.0625, -0.984375})) < 1e-15);
  CHECK(max_abs(g2 - t64({-0.625, -0.3125, -0.609375})) < 1e-15);

  auto plain = [&](const Params& q) { return (pi.log_prob(q, obs, actions) * adv).mean(); };
  auto lvc = [&](const Params& q) { return -metarl::lvc_loss(pi, q, {obs, actions, adv, {}}); };
  auto dice = [&](const Params& q) {
    const auto l = pi.log_prob(q, obs, actions);
    auto magic = [](const torch::Tensor& x) { return torch::exp(x - x.detach()); };
    return (magic(l[0]) * r1 + magic(l[0] + l[1]) * r2) / 2;
  };
  const auto grad = (A1 * g1 + A2 * g2) / 2;
  for (const auto& f : {std::function<torch::Tensor(const Params&)>(plain),
                        std::function<torch::Tensor(const Params&)>(lvc),
                        std::function<torch::Tensor(const Params&)>(dice)})
    CHECK(max_abs(flat(torch::autograd::grad({f(p)}, p)) - grad) < 1e-12);

  const auto h_plain = hessian(plain, p), h_lvc = hessian(lvc, p), h_dice = hessian(dice, p);
  CHECK(max_abs(h_plain - (A1 * H1 + A2 * H2) / 2) < 1e-12);
  CHECK(max_abs(h_lvc - (A1 * (H1 + torch::outer(g1, g1)) + A2 * (H2 + torch::outer(g2, g2))) /
                            2) < 1e-12);
  CHECK(max_abs(h_dice - h_lvc - r2 * (torch::outer(g1, g2) + torch::outer(g2, g1)) / 2) < 1e-12);
  CHECK((h_lvc - h_plain)[0][0].item<double>() == Approx(0.396484375).margin(1e-12));
  CHECK((h_dice - h_lvc)[0][0].item<double>() == Approx(-0.078125).margin(1e-12));
}

TEST_CASE("the clipped surrogate matches hand values inside and outside the clip range",
          "[metarl][promp]") {
  // clip 0.2, A = 2: min(2 r, 2 clamp(r, 0.8, 1.2)) for r = 0.5, 0.9, 1.1, 1.5
  //   = 1.0 (min(1.0, 1.6)), 1.8, 2.2, 2.4 (min(3.0, 2.4))
  // A = -1: min(-r, -clamp(r)) = -0.8 (min(-0.5, -0.8)), -0.9, -1.1, -1.5 (min(-1.5, -1.2))
  // the loss is minus the mean: -(1.0 + 1.8 + 2.2 + 2.4 - 0.8 - 0.9 - 1.1 - 1.5) / 8 = -0.3875
  const std::vector<double> r = {0.5, 0.9, 1.1, 1.5, 0.5, 0.9, 1.1, 1.5};
  const std::vector<double> a = {2, 2, 2, 2, -1, -1, -1, -1};
  const std::vector<double> objective = {1.0, 1.8, 2.2, 2.4, -0.8, -0.9, -1.1, -1.5};
  for (size_t i = 0; i < r.size(); ++i)
    CHECK(metarl::clipped_surrogate(t64({r[i]}), t64({a[i]}), 0.2).item<double>() ==
          Approx(-objective[i]).margin(1e-12));
  auto ratio = t64(r).set_requires_grad(true);
  const auto loss = metarl::clipped_surrogate(ratio, t64(a), 0.2);
  CHECK(loss.item<double>() == Approx(-0.3875).margin(1e-12));
  // the gradient -A / 8 where r A is the minimum, 0 where the clipped term is (r = 1.5 with
  // A > 0, r = 0.5 with A < 0): the clip stops the push beyond the range only
  const auto g = torch::autograd::grad({loss}, {ratio})[0];
  CHECK(max_abs(g - t64({-0.25, -0.25, -0.25, 0, 0, 0.125, 0.125, 0.125})) < 1e-12);

  // ProMP's surrogate takes the ratio against the sampling log-probabilities
  const auto pi = linear_policy();
  const auto p = linear_params(0.5, 0.25, std::log(2.0));
  const auto obs = col64({1, 2, -1, 0, 1, 2, -1, 0}), actions = col64({1, 0, 0.5, 0, 1, 0, 0, 1});
  const auto logp_old = pi.log_prob(p, obs, actions).detach() - torch::log(t64(r));
  const auto surrogate = metarl::promp_surrogate(pi, p, {obs, actions, t64(a), logp_old}, 0.2);
  CHECK(surrogate.item<double>() == Approx(-0.3875).margin(1e-12));
}

TEST_CASE("ProMP's KL term matches the closed form of two diagonal Gaussians, and the penalty "
          "adapts",
          "[metarl][promp]") {
  // KL(N(m0, s0^2) || N(m1, s1^2)) = log(s1 / s0) + (s0^2 + (m0 - m1)^2) / (2 s1^2) - 1/2 per
  // action dimension. Old: mean (x, 0), std (1, 2); new: mean (0.5 x + 0.5, x), std (2, 1).
  //   x = 1: dim 0: log 2 + (1 + 0) / 8 - 1/2;  dim 1: -log 2 + (4 + 1) / 2 - 1/2;  sum 1.625
  //   x = 2: dim 0: log 2 + (1 + 0.25) / 8 - 1/2; dim 1: -log 2 + (4 + 4) / 2 - 1/2; sum 3.15625
  //   mean over the rows: 2.390625
  // d KL / d log s1 = 1 - (s0^2 + (m0 - m1)^2) / s1^2: dim 0 mean(0.75, 0.6875) = 0.71875,
  //   dim 1 mean(-4, -7) = -5.5
  auto pi = FunctionalGaussian::init(1, {}, 2, "tanh", 1.0, 0);
  pi.to(kF64);
  const double l2 = std::log(2.0);
  const auto old_p = leaves({col64({1, 0}), t64({0, 0}), t64({0, l2})});
  const auto new_p = leaves({col64({0.5, 1}), t64({0.5, 0}), t64({l2, 0})});
  const auto obs = col64({1, 2});
  CHECK(pi.kl(old_p, new_p, obs).item<double>() == Approx(2.390625).margin(1e-12));
  const auto kl = metarl::promp_kl(pi, old_p, new_p, obs);
  CHECK(kl.item<double>() == Approx(2.390625).margin(1e-12));
  // the penalty moves the new pre-adaptation policy only
  Params both = old_p;
  both.insert(both.end(), new_p.begin(), new_p.end());
  const auto g = torch::autograd::grad({kl}, both, {}, false, false, /*allow_unused=*/true);
  for (int i = 0; i < 3; ++i) CHECK_FALSE(g[i].defined());
  CHECK(max_abs(g[5] - t64({0.71875, -5.5})) < 1e-12);
  CHECK(metarl::promp_kl(pi, new_p, new_p, obs).item<double>() == Approx(0).margin(1e-15));

  // eta doubles above 1.5 target, halves below target / 1.5, else stays
  metarl::AdaptiveKlPenalty penalty{/*eta=*/1.0, /*target=*/0.01};
  CHECK(penalty.update(0.02) == 2.0);
  CHECK(penalty.update(0.015) == 2.0);  // 1.5 target is not above it
  CHECK(penalty.update(0.012) == 2.0);
  CHECK(penalty.update(0.008) == 2.0);
  CHECK(penalty.update(0.005) == 1.0);
  CHECK(penalty.update(0.001) == 0.5);
  CHECK(penalty.eta == 0.5);
  CHECK(penalty.update(0.1) == 1.0);
  CHECK(penalty.penalty(t64({0.3})).item<double>() == Approx(0.3));
}

TEST_CASE("ProMP's per-task loss differentiates through the LVC step (finite differences)",
          "[metarl][promp]") {
  const auto sp = spread_policy(8);
  const auto& pi = sp.first;
  const auto& p = sp.second;
  torch::manual_seed(9);
  const auto pre_obs = torch::randn({6, 2}, kF64), pre_act = torch::randn({6, 2}, kF64);
  const metarl::Batch pre{pre_obs, pre_act, torch::randn({6}, kF64),
                          pi.log_prob(p, pre_obs, pre_act).detach()};
  // the sampling pre-adaptation policy is a little away from the current one (a later outer
  // epoch), so the KL has a gradient
  Params old;
  for (const auto& t : p) old.push_back(t.detach() + 0.05 * torch::randn_like(t));
  const metarl::ProMPConfig config{/*inner_lr=*/0.4, /*clip=*/0.2};
  const auto post_obs = torch::randn({5, 2}, kF64), post_act = torch::randn({5, 2}, kF64);
  // the post-adaptation rows as the adapted policy sampled them: ratio 1, inside the clip range
  // for the finite differences' small moves
  const auto adapted = metarl::lvc_inner_step(pi, p, pre, config.inner_lr, false);
  const metarl::Batch post{post_obs, post_act, torch::randn({5}, kF64),
                           pi.log_prob(adapted, post_obs, post_act).detach()};
  const double eta = 0.3;
  const auto terms = metarl::promp_task_loss(pi, p, old, pre, post, config, eta);
  CHECK(terms.loss.item<double>() ==
        Approx(terms.surrogate.item<double>() + eta * terms.kl.item<double>()).margin(1e-12));
  CHECK(terms.surrogate.item<double>() ==
        Approx(-post.advantages.mean().item<double>()).margin(1e-12));
  CHECK(terms.kl.item<double>() > 0);
  const auto exact = flat(torch::autograd::grad({terms.loss}, p));
  const auto fd = finite_difference(
      [&](const Params& q) {
        return metarl::promp_task_loss(pi, q, old, pre, post, config, eta).loss.item<double>();
      },
      p, 1e-6);
  CHECK(max_abs(exact - fd) < 1e-7);
  CHECK(max_abs(exact) > 1e-2);
}

TEST_CASE("RL^2's hidden state resets at task boundaries only, and a sequence is repeated steps",
          "[metarl][rl2]") {
  torch::manual_seed(13);
  const int64_t D = 3, A = 2, H = 8, T = 5, N = 2;
  metarl::RecurrentPolicy net(D, A, H, 0.5);
  net->to(torch::kFloat64);
  CHECK(net->input_dim() == D + A + 2);
  CHECK(max_abs(net->log_std() - std::log(0.5)) < 1e-7);  // drawn in float32

  // rl2_input: [obs, prev_action, prev_reward, prev_done] along the last axis, any leading shape
  const auto obs = torch::randn({T, N, D}, kF64), prev_a = torch::randn({T, N, A}, kF64);
  const auto prev_r = torch::randn({T, N}, kF64);
  const auto prev_d = (torch::rand({T, N}) < 0.3).to(torch::kFloat32);  // other dtype: converted
  const auto inputs = metarl::rl2_input(obs, prev_a, prev_r, prev_d).set_requires_grad(true);
  REQUIRE(inputs.sizes().vec() == std::vector<int64_t>{T, N, D + A + 2});
  CHECK(inputs.scalar_type() == torch::kFloat64);
  CHECK(torch::equal(inputs.narrow(2, 0, D), obs));
  CHECK(torch::equal(inputs.narrow(2, D, A), prev_a));
  CHECK(torch::equal(inputs.select(2, D + A), prev_r));
  CHECK(torch::equal(inputs.select(2, D + A + 1), prev_d.to(torch::kFloat64)));
  const auto one_row = metarl::rl2_input(obs[0], prev_a[0], prev_r[0], prev_d[0]);
  CHECK(torch::equal(one_row, inputs[0].detach()));

  // a new task starts at t = 3 in slot 0 only; episode ends (prev_done) are no resets
  const auto h0 = torch::randn({1, N, H}, kF64);
  auto resets = torch::zeros({T, N}, kF64);
  resets[3][0] = 1;
  const auto [means, values, hiddens] = net->forward_sequence(inputs, h0, resets);
  REQUIRE(means.sizes().vec() == std::vector<int64_t>{T, N, A});
  REQUIRE(values.sizes().vec() == std::vector<int64_t>{T, N});
  REQUIRE(hiddens.sizes().vec() == std::vector<int64_t>{T, N, H});

  // slot 0 at t = 3 is a fresh start: forward_step from zeros on the same input
  const auto zero = net->initial_hidden(1);
  CHECK(max_abs(zero) == 0);
  const auto [m0, v0, h_fresh] = net->forward_step(inputs[3].narrow(0, 0, 1), zero);
  CHECK(max_abs(means[3][0] - m0[0]) < 1e-12);
  CHECK(max_abs(values[3][0] - v0[0]) < 1e-12);
  CHECK(max_abs(hiddens[3][0] - h_fresh[0][0]) < 1e-12);
  // slot 1 keeps its memory: from zeros its step would differ
  const auto [m1, v1, h1] = net->forward_step(inputs[3].narrow(0, 1, 1), zero);
  CHECK(max_abs(hiddens[3][1] - h1[0][0]) > 1e-3);
  CHECK(max_abs(means[3][1] - m1[0]) > 1e-6);

  // the sequence is forward_step repeated, with the reset applied by hand
  auto h = h0;
  for (int64_t t = 0; t < T; ++t) {
    if (t == 3) h = torch::stack({torch::zeros({H}, kF64), h[0][1]}).unsqueeze(0);
    const auto [m, v, h_next] = net->forward_step(inputs[t], h);
    CHECK(max_abs(means[t] - m) < 1e-12);
    CHECK(max_abs(values[t] - v) < 1e-12);
    CHECK(max_abs(hiddens[t] - h_next[0]) < 1e-12);
    h = h_next;
  }
  // with no reset it is also LibTorch's GRU over the whole sequence (the heads read its output)
  const auto [m_free, v_free, h_free] =
      net->forward_sequence(inputs, h0, torch::zeros({T, N}, kF64));
  auto gru = net->named_children()["gru"]->as<torch::nn::GRU>();
  REQUIRE(gru != nullptr);
  const auto out = std::get<0>(gru->forward(inputs, h0));
  CHECK(max_abs(h_free - out) < 1e-12);
  // the reset changed slot 0 from t = 3 on and nothing else
  CHECK(max_abs(m_free.narrow(0, 0, 3) - means.narrow(0, 0, 3)) < 1e-12);
  CHECK(max_abs(m_free.select(1, 1) - means.select(1, 1)) < 1e-12);
  CHECK(max_abs(m_free[4][0] - means[4][0]) > 1e-6);

  // no gradient crosses the reset: slot 0's last mean does not depend on its inputs before t = 3,
  // slot 1's does
  const auto g = torch::autograd::grad({means[4][0].sum() + means[4][1].sum()}, {inputs})[0];
  CHECK(max_abs(g.narrow(0, 0, 3).select(1, 0)) == 0);
  CHECK(max_abs(g.narrow(0, 3, 2).select(1, 0)) > 0);
  CHECK(max_abs(g.narrow(0, 0, 3).select(1, 1)) > 0);

  // shapes are checked at the call
  CHECK_THROWS(net->forward_step(inputs[0].narrow(1, 0, D), zero));
  CHECK_THROWS(net->forward_sequence(inputs, h0, torch::zeros({T}, kF64)));
  CHECK_THROWS_AS(metarl::RecurrentPolicy(D, A, 0, 0.5), std::invalid_argument);
}
