// rl/sac: the critics' target, the temperature's loss and the squashed Gaussian's density against
// hand-worked values, a SAC run's checkpoints, SAC's and MTSAC's updates with FlatAdam against
// the same updates with LibTorch's Adam, and the CUDA graph's setting.
#include "tests/rl/mirror_fixture.h"

#include <cmath>

#include "core/error.h"
#include "core/files.h"
#include "rl/checkpoint.h"
#include "rl/policy.h"
#include "rl/replay.h"
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

// sac.cuda_graph replays an update as a CUDA graph on a CUDA device only (rl/cuda_graph.h; its
// speed is measured on a GPU, bench/results/learner-equiv-h200, and its learning,
// bench/results/offpolicy-graph-h200x2): on by default for sac, off for mtsac (not measured in a
// multi-task run), a setting of both, and checked. (The replay itself needs a GPU; the update it
// captures is the one the FlatAdam mirror tests below check.)
TEST_CASE("sac.cuda_graph is on by default for sac, off for mtsac, and a checked setting of both",
          "[rl][sac][mtsac]") {
  auto yaml = [](const std::string& algo, const std::string& target,
                 const std::vector<std::string>& extra) {
    std::vector<std::string> o = tiny_sac();
    o.insert(o.end(), extra.begin(), extra.end());  // after tiny_sac's: they win
    return rl::resolve_train_yaml(rl::default_train_config(algo), algo, target, o);
  };
  CHECK(rl::parse_train_config(yaml("sac", "catch_underarm_raise", {}), "x").sac.cuda_graph);
  CHECK_FALSE(rl::parse_train_config(yaml("mtsac", "MT4", {}), "x").sac.cuda_graph);
  CHECK(rl::parse_train_config(yaml("mtsac", "MT4", {"sac.cuda_graph=true"}), "x").sac.cuda_graph);
  try {
    yaml("sac", "catch_underarm_raise", {"sac.cuda_graph=sometimes"});
    FAIL("accepted");
  } catch (const ConfigError& err) {
    CHECK(err.key() == "sac.cuda_graph");
    CHECK_THAT(err.what(), Catch::Contains("true or false") && Catch::Contains("sometimes"));
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

namespace {

// rl/sac.cc's actor (its module "net" of 2A outputs: the mean and the clamped log-std).
struct MirrorSacActor : torch::nn::Module {
  MirrorSacActor(int64_t D, int64_t A, const rl::SacConfig& c) : act_dim(A) {
    net = register_module("net", rl::mlp(D, c.hidden, 2 * A, c.activation, 0.01));
  }
  std::pair<torch::Tensor, torch::Tensor> sample(const torch::Tensor& obs) {
    auto out = net->forward(obs);
    auto mu = out.narrow(1, 0, act_dim), log_std = out.narrow(1, act_dim, act_dim).clamp(-20, 2);
    auto u = mu + torch::exp(log_std) * torch::randn_like(mu);
    return {torch::tanh(u), rl::tanh_gaussian_log_prob(u, mu, log_std)};
  }
  int64_t act_dim;
  torch::nn::Sequential net{nullptr};
};

// SAC's update (rl/sac.cc) as it was with LibTorch's Adam and clip_grad_norm_, on copies of a
// SAC's networks and temperature read from its checkpoint state.
struct SacMirror {
  SacMirror(const rl::SacConfig& config, int64_t D, int64_t A, int64_t ntasks,
            torch::serialize::InputArchive& root)
      : c(config),
        ntasks(ntasks),
        target_entropy(-static_cast<double>(A)),
        actor(std::make_shared<MirrorSacActor>(D, A, config)),
        critic(D, A, config.hidden, config.activation, true),
        target(D, A, config.hidden, config.activation, true) {
    test::load_part(root, "actor", *actor);
    test::load_part(root, "critic", *critic);
    test::load_part(root, "target", *target);
    root.read("log_alpha", log_alpha);
    log_alpha = log_alpha.detach().clone().set_requires_grad(true);
    actor_opt = std::make_unique<torch::optim::Adam>(actor->parameters(),
                                                     torch::optim::AdamOptions(c.lr));
    critic_opt = std::make_unique<torch::optim::Adam>(critic->parameters(),
                                                      torch::optim::AdamOptions(c.lr));
    alpha_opt = std::make_unique<torch::optim::Adam>(std::vector<torch::Tensor>{log_alpha},
                                                     torch::optim::AdamOptions(c.lr));
  }

  // the metrics of SacAlgorithm::update
  std::vector<double> update(const rl::ReplayBuffer& replay) {
    std::vector<double> sums(6, 0.0);
    for (int k = 0; k < c.minibatches; ++k) {
      const auto b = replay.sample(c.batch_size);
      const torch::Tensor row_log_alpha =
          ntasks > 0 ? log_alpha.index_select(0, rl::task_ids(b.obs, ntasks)) : log_alpha;
      const torch::Tensor alpha = torch::exp(row_log_alpha).detach();
      torch::Tensor y;
      {
        torch::NoGradGuard ng;
        auto [a_next, logp_next] = actor->sample(b.next_obs);
        auto [q1n, q2n] = target->forward(b.next_obs, a_next);
        const torch::Tensor alpha_next =
            ntasks > 0 ? torch::exp(log_alpha.index_select(0, rl::task_ids(b.next_obs, ntasks)))
                       : alpha;
        y = rl::sac_q_target(b.rewards, b.terminal, q1n, q2n, logp_next, alpha_next, c.gamma);
      }
      auto [q1, q2] = critic->forward(b.obs, b.actions);
      auto q_loss = 0.5 * ((q1 - y).pow(2).mean() + (q2 - y).pow(2).mean());
      critic_opt->zero_grad();
      q_loss.backward();
      critic_norms.push_back(
          torch::nn::utils::clip_grad_norm_(critic->parameters(), c.max_grad_norm));
      critic_opt->step();
      auto [a_new, logp] = actor->sample(b.obs);
      auto [q1p, q2p] = critic->forward(b.obs, a_new);
      auto actor_loss = (alpha * logp - torch::min(q1p, q2p)).mean();
      actor_opt->zero_grad();
      actor_loss.backward();
      actor_norms.push_back(
          torch::nn::utils::clip_grad_norm_(actor->parameters(), c.max_grad_norm));
      actor_opt->step();
      auto alpha_loss = rl::sac_alpha_loss(row_log_alpha, logp, target_entropy);
      if (c.learn_alpha) {
        alpha_opt->zero_grad();
        alpha_loss.backward();
        alpha_opt->step();
      }
      rl::polyak_update(*critic, *target, c.polyak);
      torch::NoGradGuard ng;
      const double row[6] = {q_loss.item<double>(),
                             actor_loss.item<double>(),
                             alpha_loss.item<double>(),
                             -logp.mean().item<double>(),
                             q1.mean().item<double>(),
                             torch::exp(log_alpha).mean().item<double>()};
      for (int i = 0; i < 6; ++i) sums[i] += row[i] / c.minibatches;
    }
    return sums;
  }

  rl::SacConfig c;
  int64_t ntasks;
  double target_entropy;
  std::shared_ptr<MirrorSacActor> actor;
  rl::QCritic critic, target;
  torch::Tensor log_alpha;
  std::unique_ptr<torch::optim::Adam> actor_opt, critic_opt, alpha_opt;
  std::vector<double> critic_norms, actor_norms;  // the clips' norms
};

}  // namespace

TEST_CASE("SAC's and MTSAC's FlatAdam updates step as LibTorch's Adam with clip_grad_norm_ did",
          "[rl][sac][mtsac][flat_adam]") {
  for (const std::string algo : {"sac", "mtsac"}) {
    INFO(algo);
    // a learned temperature (catch_underarm_raise's default fixes it), a rate that moves the
    // weights well beyond the tolerance, and a clip that binds on every critic step and some
    // actor steps
    std::vector<std::string> o = tiny_sac();
    for (const char* e : {"sac.minibatches=3", "sac.learn_alpha=true", "sac.init_alpha=0.2",
                          "sac.lr=1e-3", "sac.max_grad_norm=0.5"})
      o.push_back(e);
    const bool mt = algo == "mtsac";
    const rl::TrainConfig c = rl::parse_train_config(
        rl::resolve_train_yaml(rl::default_train_config(algo), algo,
                               mt ? "MT4" : "catch_underarm_raise", o),
        "tiny");
    REQUIRE(c.sac.learn_alpha);
    // MT4's four train tasks: the last 4 columns are the one-hot task id
    const int64_t N = 8, ntasks = mt ? 4 : 0, D = 5 + ntasks, A = 3;
    torch::manual_seed(3);
    auto alg = rl::make_algorithm(algo, c, D, A, N, torch::Device(torch::kCPU));
    auto observation = [&] {
      auto obs = torch::randn({N, D});
      if (mt)
        obs.narrow(1, D - ntasks, ntasks)
            .copy_(torch::one_hot(torch::randint(ntasks, {N}), ntasks).to(torch::kFloat32));
      return obs;
    };
    // three steps of every slot into the learner's replay buffer and an identical one
    rl::ReplayBuffer replay(c.sac.replay_size, D, A, torch::Device(torch::kCPU));
    auto obs = observation();
    for (int t = 0; t < 3; ++t) {
      const auto a = alg->act(obs);
      rl::Transition tr;
      tr.obs = observation();
      tr.reward = torch::randn({N});
      // slot 1's episode ends by itself (terminal), slot 2's at its time limit (bootstrapped)
      tr.done = torch::zeros({N});
      tr.done.narrow(0, 1, 2).fill_(1);
      tr.final_ids = torch::tensor({int64_t(2)});
      tr.final_obs = observation().narrow(0, 0, 1);
      alg->observe(tr);
      replay.add(obs, a, tr, c.sac.reward_scale);
      obs = tr.obs;
    }
    auto start = test::saved_state(*alg);
    SacMirror mirror(c.sac, D, A, ntasks, start);
    const auto actor0 = test::param_copies(*mirror.actor);
    const auto critic0 = test::param_copies(*mirror.critic);
    const auto log_alpha0 = mirror.log_alpha.detach().clone();
    // two updates of three gradient steps, each from the same seed
    for (int u = 0; u < 2; ++u) {
      torch::manual_seed(100 + u);
      const auto got = alg->update(obs);
      torch::manual_seed(100 + u);
      const auto want = mirror.update(replay);
      REQUIRE(got.size() == want.size());
      for (size_t i = 0; i < got.size(); ++i) {
        INFO("update " << u << ", " << alg->metric_names()[i]);
        CHECK(got[i] == Approx(want[i]).epsilon(1e-4).margin(1e-5));
      }
    }
    test::check_clips(mirror.critic_norms, mirror.actor_norms, c.sac.max_grad_norm);
    auto after = test::saved_state(*alg);
    MirrorSacActor actor(D, A, c.sac);
    rl::QCritic critic(D, A, c.sac.hidden, c.sac.activation, true),
        target(D, A, c.sac.hidden, c.sac.activation, true);
    test::load_part(after, "actor", actor);
    test::load_part(after, "critic", *critic);
    test::load_part(after, "target", *target);
    torch::Tensor log_alpha;
    after.read("log_alpha", log_alpha);
    CHECK(test::max_param_diff(actor, *mirror.actor) < test::kMirrorTol);
    CHECK(test::max_param_diff(*critic, *mirror.critic) < test::kMirrorTol);
    CHECK(test::max_param_diff(*target, *mirror.target) < test::kMirrorTol);
    CHECK(test::max_diff({log_alpha}, {mirror.log_alpha.detach()}) < test::kMirrorTol);
    // ... while every part moved far more than that
    CHECK(test::max_diff(actor0, actor.parameters()) > 100 * test::kMirrorTol);
    CHECK(test::max_diff(critic0, critic->parameters()) > 100 * test::kMirrorTol);
    CHECK(test::max_diff({log_alpha0}, {log_alpha}) > 100 * test::kMirrorTol);
  }
}
