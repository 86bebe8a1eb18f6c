// marl/onpolicy: HAPPO's sequential correction and HATRPO's step against hand-worked cases, what
// each critic sees, shared actors, checkpoints of every member, a one-step bandit each member
// learns, and tiny runs of IPPO, MAPPO, HAPPO and HATRPO through the learning core (train,
// resume, evaluate).
#include "tests/rl/rl_fixture.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/files.h"
#include "marl/agents.h"
#include "marl/algorithms.h"
#include "marl/config.h"
#include "marl/nets.h"
#include "marl/onpolicy.h"
#include "rl/algorithm.h"
#include "rl/checkpoint.h"
#include "rl/policy.h"
#include "tasks/registry.h"

using namespace bidex;

namespace {

const char* const kAlgos[] = {"ippo", "mappo", "happo", "hatrpo"};

// `algo` on hand_over from its real YAML, small networks on the CPU, then `extra` overrides.
rl::TrainConfig config(const std::string& algo, std::vector<std::string> extra = {}) {
  marl::register_algorithms();
  std::vector<std::string> o = {"train.device=cpu", "train.torch_threads=1",
                                algo + ".hidden=[32]"};
  for (auto& e : extra) o.push_back(e);
  return rl::parse_train_config(
      rl::resolve_train_yaml(rl::default_train_config(algo), algo, "hand_over", o), algo);
}

const tasks::TaskSpec& hand_over() { return tasks::find_task("hand_over").spec(); }

std::unique_ptr<marl::OnPolicyMarl> make(const rl::TrainConfig& c, int64_t nslot) {
  auto a = rl::make_algorithm(c.algo, c, hand_over().obs.dim(), hand_over().act.dim(), nslot,
                              torch::kCPU);
  auto* m = dynamic_cast<marl::OnPolicyMarl*>(a.get());
  REQUIRE(m);
  a.release();
  return std::unique_ptr<marl::OnPolicyMarl>(m);
}

// One rollout of fixed observations whose reward is the mean of the first action of each hand
// (larger is better), then an update; returns its metrics.
std::vector<double> rollout_and_update(rl::Algorithm& algo, const torch::Tensor& obs) {
  const auto split = marl::hand_split(hand_over());
  const int64_t r0 = split.agents[0].act_cols[0], l0 = split.agents[1].act_cols[0];
  for (int t = 0; t < algo.steps_per_update(); ++t) {
    const auto a = algo.act(obs);
    rl::Transition tr;
    tr.obs = obs;
    tr.reward = 0.5 * (a.select(1, r0) + a.select(1, l0));
    tr.done = torch::ones({obs.size(0)});
    tr.final_ids = torch::zeros({0}, torch::kLong);
    tr.final_obs = torch::zeros({0, obs.size(1)});
    algo.observe(tr);
  }
  return algo.update(obs);
}

// A Gaussian actor whose mean is linear in its observation (no hidden layers, no LayerNorm).
marl::OnPolicyConfig linear_config() {
  marl::OnPolicyConfig c;
  c.net.hidden = {};
  c.net.feature_norm = false;
  c.net.layer_norm = false;
  c.epochs = 1;
  c.minibatches = 1;
  c.clip = 0.2;
  c.entropy_coef = 0;
  return c;
}

void set_linear(marl::GaussianActor& a, std::vector<float> w, float b, float log_std) {
  torch::NoGradGuard ng;
  auto p = a->named_parameters();
  p["mean.weight"].copy_(torch::tensor(w).reshape({1, -1}));
  p["mean.bias"].fill_(b);
  p["log_std"].fill_(log_std);
}

double sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }
// log N(a; mu, s)
double log_normal(double a, double mu, double s) {
  return -0.5 * std::pow((a - mu) / s, 2) - std::log(s) - 0.5 * std::log(2 * M_PI);
}

}  // namespace

TEST_CASE("HAPPO's factor is the first agent's probability ratio and weights the second's "
          "clipped surrogate",
          "[marl]") {
  const marl::OnPolicyConfig c = linear_config();
  // three samples of 2-d observations; agent 1 and agent 2 each set one action
  const std::vector<std::vector<double>> o = {{1.0, 0.5}, {-0.5, 2.0}, {0.3, -1.0}};
  const std::vector<double> A = {1.0, -0.5, 2.0};
  const auto obs = torch::tensor({1.0f, 0.5f, -0.5f, 2.0f, 0.3f, -1.0f}).reshape({3, 2});
  const auto adv = torch::tensor({1.0f, -0.5f, 2.0f});

  // agent 1: mean 0.5 o0 - 0.3 o1 + 0.1, std sigmoid(0) x 0.5 = 0.25; the rollout was its own
  marl::GaussianActor a1(2, 1, c);
  set_linear(a1, {0.5f, -0.3f}, 0.1f, 0.0f);
  const std::vector<double> act1 = {0.4, -0.6, 0.2};
  std::vector<double> mu1(3), lp1(3);
  for (int k = 0; k < 3; ++k) {
    mu1[k] = 0.5 * o[k][0] - 0.3 * o[k][1] + 0.1;
    lp1[k] = log_normal(act1[k], mu1[k], 0.25);
  }
  marl::AgentBatch b1{obs,
                      torch::tensor(std::vector<float>(act1.begin(), act1.end())).reshape({3, 1}),
                      torch::tensor(std::vector<float>(lp1.begin(), lp1.end())),
                      torch::tensor(std::vector<float>(mu1.begin(), mu1.end())).reshape({3, 1}),
                      torch::full({1}, std::log(0.25f)),
                      adv};
  torch::optim::Adam opt1(a1->parameters(), torch::optim::AdamOptions(0.05));
  const auto s1 = marl::ppo_actor_update(a1, opt1, b1, {}, c);
  // ratio 1 before its step: the loss is -mean(A)
  CHECK(s1[0].item<double>() == Approx(-(1.0 - 0.5 + 2.0) / 3).epsilon(1e-5));
  CHECK(s1[3].item<double>() == 0);  // nothing clipped

  // its factor, from its new parameters by hand: the ratio of the new density to the old
  auto p = a1->named_parameters();
  const double w0 = p["mean.weight"][0][0].item<double>();
  const double w1 = p["mean.weight"][0][1].item<double>();
  const double bias = p["mean.bias"][0].item<double>();
  const double s_new = sigmoid(p["log_std"][0].item<double>()) * 0.5;
  std::vector<double> factor(3);
  for (int k = 0; k < 3; ++k) {
    const double mu = w0 * o[k][0] + w1 * o[k][1] + bias;
    factor[k] = std::exp(log_normal(act1[k], mu, s_new) - lp1[k]);
  }
  torch::Tensor f;
  {
    torch::NoGradGuard ng;
    f = marl::next_factor(torch::ones({3}), a1->log_prob(b1.obs, b1.actions), b1.logp_old);
  }
  for (int k = 0; k < 3; ++k) {
    CHECK(f[k].item<double>() == Approx(factor[k]).epsilon(1e-4));
    CHECK(std::abs(factor[k] - 1.0) > 1e-3);  // agent 1 did move
  }

  // agent 2: mean -0.2 o0 + 0.4 o1, std sigmoid(0.5) x 0.5; its rollout policy's means were
  // shifted, so that its ratios fall inside and outside [0.8, 1.2]
  marl::GaussianActor a2(2, 1, c);
  set_linear(a2, {-0.2f, 0.4f}, 0.0f, 0.5f);
  const double s2 = sigmoid(0.5) * 0.5;
  const std::vector<double> act2 = {0.1, 0.9, -0.5}, shift = {0.02, 0.3, -0.25};
  std::vector<double> mu2_old(3), lp2_old(3), r2(3);
  double expected = 0;
  int clipped = 0;
  for (int k = 0; k < 3; ++k) {
    const double mu = -0.2 * o[k][0] + 0.4 * o[k][1];
    mu2_old[k] = mu + shift[k];
    lp2_old[k] = log_normal(act2[k], mu2_old[k], s2);
    r2[k] = std::exp(log_normal(act2[k], mu, s2) - lp2_old[k]);
    const double rc = std::min(std::max(r2[k], 0.8), 1.2);
    expected += factor[k] * std::min(r2[k] * A[k], rc * A[k]);
    clipped += std::abs(r2[k] - 1) > 0.2;
  }
  expected = -expected / 3;
  INFO("agent 2's ratios " << r2[0] << " " << r2[1] << " " << r2[2]);
  REQUIRE(clipped >= 1);
  REQUIRE(clipped < 3);
  const auto ratio2 = torch::tensor(std::vector<float>(r2.begin(), r2.end()));
  CHECK(marl::happo_surrogate(ratio2, adv, f, 0.2).item<double>() ==
        Approx(expected).epsilon(1e-4));
  // without the factor it is PPO's surrogate, which differs here
  CHECK(marl::happo_surrogate(ratio2, adv, {}, 0.2).item<double>() !=
        Approx(expected).epsilon(1e-3));
  // the update reports the loss before its step: the same number
  marl::AgentBatch b2{obs,
                      torch::tensor(std::vector<float>(act2.begin(), act2.end())).reshape({3, 1}),
                      torch::tensor(std::vector<float>(lp2_old.begin(), lp2_old.end())),
                      torch::tensor(std::vector<float>(mu2_old.begin(), mu2_old.end()))
                          .reshape({3, 1}),
                      torch::full({1}, static_cast<float>(std::log(s2))),
                      adv};
  torch::optim::Adam opt2(a2->parameters(), torch::optim::AdamOptions(0.05));
  const auto s2_stats = marl::ppo_actor_update(a2, opt2, b2, f, c);
  CHECK(s2_stats[0].item<double>() == Approx(expected).epsilon(1e-4));
  CHECK(s2_stats[3].item<double>() == Approx(clipped / 3.0));
  // HATRPO's surrogate of the same numbers: -mean(factor r A)
  double trpo = 0;
  for (int k = 0; k < 3; ++k) trpo += factor[k] * r2[k] * A[k];
  CHECK(marl::hatrpo_surrogate(ratio2, adv, f).item<double>() == Approx(-trpo / 3).epsilon(1e-4));
}

TEST_CASE("HAPPO's first agent in a fixed order learns as MAPPO's, the second under the factor",
          "[marl]") {
  const std::vector<std::string> common = {"epochs=4", "lr=0.01"};
  auto with = [&](const std::string& algo, std::vector<std::string> extra) {
    for (auto& e : common) extra.push_back(algo + "." + e);
    return config(algo, extra);
  };
  const auto split = marl::hand_split(hand_over());
  const int64_t N = 32, D = hand_over().obs.dim();
  torch::manual_seed(3);
  const auto obs = torch::randn({N, D});
  std::vector<torch::Tensor> acted;
  for (const char* algo : {"mappo", "happo"}) {
    torch::manual_seed(11);
    auto a = make(with(algo, {std::string(algo) == "happo" ? "happo.fixed_order=true"
                                                             : "mappo.share_actor=false"}),
                  N);
    rollout_and_update(*a, obs);
    acted.push_back(a->actor(obs));
  }
  const auto right = torch::tensor(split.agents[0].act_cols);
  const auto left = torch::tensor(split.agents[1].act_cols);
  // the first agent's update is MAPPO's exactly (factor 1)
  CHECK(torch::equal(acted[0].index_select(1, right), acted[1].index_select(1, right)));
  // the second's surrogate is weighted by the first's ratios
  const double diff =
      (acted[0].index_select(1, left) - acted[1].index_select(1, left)).abs().max().item<double>();
  INFO("largest difference of the second agent's actions " << diff);
  CHECK(diff > 1e-5);
}

TEST_CASE("HATRPO's step keeps its KL bound, improves the weighted surrogate, and stands still "
          "without advantages",
          "[marl]") {
  torch::manual_seed(5);
  marl::OnPolicyConfig c;
  c.net.hidden = {16};
  c.kl_threshold = 0.01;
  marl::GaussianActor actor(3, 2, c);
  const int64_t B = 256;
  marl::AgentBatch b;
  b.obs = torch::randn({B, 3});
  {
    torch::NoGradGuard ng;
    b.mu_old = actor->mean(b.obs);
    b.log_std_old = actor->log_std();
    b.actions = b.mu_old + torch::exp(b.log_std_old) * torch::randn({B, 2});
    b.logp_old = rl::gaussian_log_prob(b.actions, b.mu_old, b.log_std_old);
  }
  // better actions have a larger first component; the factor of agents before it in (0.5, 1.5)
  auto adv = b.actions.select(1, 0) - b.actions.select(1, 0).mean();
  b.adv = adv / adv.std();
  const auto factor = 0.5 + torch::rand({B});
  auto flat = [&] {
    std::vector<torch::Tensor> ps;
    for (auto& p : actor->parameters()) ps.push_back(p.detach().reshape({-1}).clone());
    return torch::cat(ps);
  };
  const auto before = flat();
  const rl::NaturalStep st = marl::trpo_actor_update(actor, b, factor, c);
  INFO("fraction " << st.fraction << ", kl " << st.kl << ", loss " << st.loss);
  CHECK(st.fraction > 0);
  CHECK(st.kl > 0);
  CHECK(st.kl <= c.kl_threshold * 1.0001);
  CHECK(st.loss == Approx(-(factor * b.adv).mean().item<double>()).epsilon(1e-4));
  {
    torch::NoGradGuard ng;
    const auto mu = actor->mean(b.obs);
    const auto ls = actor->log_std();
    const double kl = rl::gaussian_kl(b.mu_old, b.log_std_old, mu, ls).mean().item<double>();
    CHECK(kl == Approx(st.kl).epsilon(1e-4));
    const auto ratio = torch::exp(rl::gaussian_log_prob(b.actions, mu, ls) - b.logp_old);
    const double after = marl::hatrpo_surrogate(ratio, b.adv, factor).item<double>();
    CHECK(after < st.loss - 1e-3);
  }
  CHECK_FALSE(torch::equal(flat(), before));

  // no advantage: no direction, no step
  const auto moved = flat();
  b.mu_old = actor->mean(b.obs).detach();
  b.log_std_old = actor->log_std().detach();
  b.logp_old = rl::gaussian_log_prob(b.actions, b.mu_old, b.log_std_old).detach();
  b.adv = torch::zeros({B});
  const rl::NaturalStep none = marl::trpo_actor_update(actor, b, factor, c);
  CHECK(none.fraction == 0);
  CHECK(none.loss == 0);
  CHECK(torch::equal(flat(), moved));
}

TEST_CASE("IPPO's critics see their own agent's columns, MAPPO's critic the whole observation",
          "[marl]") {
  const auto split = marl::hand_split(hand_over());
  const int64_t D = hand_over().obs.dim();
  // columns agent 0 (right) does not see: the left hand's block
  std::vector<int64_t> unseen;
  for (int64_t col = 0; col < D; ++col)
    if (!std::binary_search(split.agents[0].obs_cols.begin(), split.agents[0].obs_cols.end(), col))
      unseen.push_back(col);
  REQUIRE_FALSE(unseen.empty());
  torch::manual_seed(2);
  const auto obs = torch::randn({4, D});
  auto other = obs.clone();
  other.index_fill_(1, torch::tensor(unseen), 3.0);

  auto ippo = make(config("ippo"), 4);
  const auto v = ippo->values(obs), w = ippo->values(other);
  REQUIRE(v.sizes() == torch::IntArrayRef({4, 2}));
  CHECK(torch::equal(v.select(1, 0), w.select(1, 0)));
  CHECK((v.select(1, 1) - w.select(1, 1)).abs().max().item<double>() > 1e-4);

  auto mappo = make(config("mappo"), 4);
  const auto cv = mappo->values(obs), cw = mappo->values(other);
  REQUIRE(cv.sizes() == torch::IntArrayRef({4, 1}));
  CHECK((cv - cw).abs().max().item<double>() > 1e-4);
  CHECK(mappo->agents() == 2);
  CHECK(mappo->actors() == 2);
}

TEST_CASE("MAPPO shares one actor among agents of equal widths and refuses unequal ones",
          "[marl]") {
  const int64_t N = 8, D = hand_over().obs.dim();
  auto shared = make(config("mappo", {"mappo.share_actor=true", "mappo.horizon=2"}), N);
  CHECK(shared->actors() == 1);
  const auto m = rollout_and_update(*shared, torch::randn({N, D}));
  for (double x : m) CHECK(std::isfinite(x));
  // finger agents: the palm's widths are not a finger's
  try {
    make(config("mappo", {"mappo.share_actor=true", "mappo.agents=finger"}), N);
    FAIL("made");
  } catch (const Error& e) {
    const std::string msg = e.what();
    INFO(msg);
    CHECK(msg.find("mappo.share_actor") != std::string::npos);
    CHECK(msg.find("equal") != std::string::npos);
    CHECK(msg.find("right_palm sees") != std::string::npos);
    CHECK(msg.find("left_th sees") != std::string::npos);
  }
}

TEST_CASE("a split of other widths than the run's is refused naming both", "[marl]") {
  const auto c = config("happo");
  const int64_t D = hand_over().obs.dim(), A = hand_over().act.dim();
  try {
    rl::make_algorithm("happo", c, D + 1, A, 4, torch::kCPU);
    FAIL("made");
  } catch (const Error& e) {
    const std::string msg = e.what();
    INFO(msg);
    CHECK(msg.find("width " + std::to_string(D)) != std::string::npos);
    CHECK(msg.find(std::to_string(D + 1)) != std::string::npos);
  }
}

TEST_CASE("every member's checkpoint restores training and acting, and another split's is "
          "refused naming the file",
          "[marl]") {
  test::TaskTempDir tmp;
  const int64_t N = 8, D = hand_over().obs.dim(), A = hand_over().act.dim();
  torch::manual_seed(4);
  const auto obs = torch::randn({N, D}) * 2 + 1;
  for (const char* algo : kAlgos) {
    DYNAMIC_SECTION(algo) {
      const std::string s = algo;
      const auto c = config(s, {s + ".obs_norm=true", s + ".horizon=2"});
      torch::manual_seed(1);
      auto trained = make(c, N);
      rollout_and_update(*trained, obs);
      torch::serialize::OutputArchive out;
      trained->save(out);
      rl::CheckpointMeta meta;
      meta.task = "hand_over";
      meta.algo = s;
      meta.obs_dim = D;
      meta.act_dim = A;
      const std::string path = tmp.file(s + ".ckpt");
      rl::save_checkpoint(path, meta, out);
      const auto saved_actions = trained->actor(obs);
      auto read = [&] {
        auto root = std::make_unique<torch::serialize::InputArchive>();
        rl::load_checkpoint(path, *root, torch::kCPU);
        return root;
      };

      torch::manual_seed(2);  // other initial weights
      auto resumed = make(c, N);
      REQUIRE_FALSE(torch::equal(resumed->actor(obs), trained->actor(obs)));
      resumed->load(*read(), path);
      CHECK(torch::equal(resumed->actor(obs), trained->actor(obs)));
      CHECK(torch::equal(resumed->values(obs), trained->values(obs)));
      // training goes on the same from both (the optimisers' state came along)
      torch::manual_seed(6);
      const auto m1 = rollout_and_update(*trained, obs);
      torch::manual_seed(6);
      const auto m2 = rollout_and_update(*resumed, obs);
      CHECK(m1 == m2);
      CHECK(torch::equal(resumed->actor(obs), trained->actor(obs)));

      // acting alone: the actors and the observation normaliser
      torch::manual_seed(3);
      auto acting = make(c, 0);
      acting->load_actor(*read(), path);
      CHECK(torch::equal(acting->actor(obs), saved_actions));

      // finger agents cannot take a hand split's checkpoint
      auto finger = make(config(s, {s + ".obs_norm=true", s + ".agents=finger"}), N);
      for (bool actor_only : {false, true}) {
        try {
          if (actor_only) finger->load_actor(*read(), path);
          else finger->load(*read(), path);
          FAIL("loaded");
        } catch (const Error& e) {
          const std::string msg = e.what();
          INFO(msg);
          CHECK(msg.find(path) != std::string::npos);
          CHECK(msg.find("holds 2 agents") != std::string::npos);
          CHECK(msg.find("finger split has 12") != std::string::npos);
        }
      }
    }
  }
}

TEST_CASE("IPPO, MAPPO, HAPPO and HATRPO train, resume and evaluate on catch_underarm_raise",
          "[marl]") {
  marl::register_algorithms();
  test::TaskTempDir tmp;
  for (const char* algo : kAlgos) {
    DYNAMIC_SECTION(algo) {
      const std::string dir = tmp.file(algo);
      auto o = test::quiet();
      o.stop_after_updates = 1;
      auto r = rl::train_new(test::tiny_onpolicy_yaml(algo, "catch_underarm_raise"), dir, o);
      CHECK(r.interrupted);
      CHECK(r.updates == 1);
      CHECK(rl::read_checkpoint_meta(rl::list_checkpoints(dir).back()).algo == algo);
      r = rl::train_resume(dir, test::quiet());
      CHECK(r.updates == 2);
      CHECK_FALSE(r.interrupted);
      const std::string csv = read_file(dir + "/metrics.csv");
      const bool trpo = std::string(algo) == "hatrpo";
      CHECK(csv.find(trpo ? "step_fraction" : "clip_fraction") != std::string::npos);
      CHECK(csv.find("action_std") != std::string::npos);
      rl::LoadedPolicy p(dir);
      CHECK(p.update() == 2);
      const auto e = rl::evaluate(p, 4, 3, 1);
      CHECK(e.episodes == 4);
      CHECK(std::isfinite(e.mean_return));
    }
  }
}

TEST_CASE("every member raises the probability of better actions (one-step bandit)", "[marl]") {
  const auto split = marl::hand_split(hand_over());
  const int64_t r0 = split.agents[0].act_cols[0], l0 = split.agents[1].act_cols[0];
  const int64_t N = 64, D = hand_over().obs.dim();
  for (const char* algo : kAlgos) {
    DYNAMIC_SECTION(algo) {
      const std::string s = algo;
      torch::manual_seed(9);
      auto a = make(config(s, {s + ".horizon=4"}), N);
      const auto obs = torch::randn({1, D}).expand({N, D}).contiguous();
      auto first = [&] {
        const auto m = a->actor(obs.narrow(0, 0, 1));
        return std::make_pair(m[0][r0].item<double>(), m[0][l0].item<double>());
      };
      const auto before = first();
      for (int it = 0; it < 10; ++it) {
        const auto m = rollout_and_update(*a, obs);
        INFO("update " << it << ": kl " << m[3] << ", " << a->metric_names()[4] << " " << m[4]);
        if (s == "hatrpo") CHECK(m[3] <= 0.016 * 1.0001);
      }
      const auto after = first();
      INFO(s << ": right " << before.first << " -> " << after.first << ", left "
             << before.second << " -> " << after.second);
      CHECK(after.first > before.first + 0.2);
      CHECK(after.second > before.second + 0.2);
    }
  }
}
