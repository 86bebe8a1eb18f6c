// marl/maddpg: the critic's target and the joint action against hand-worked values; an actor
// step moves its own agent's actor alone and raises Q; warmup acts uniformly without the
// actors, then the actors act in their own columns; checkpoints load, and one of another split
// or width is refused naming the file; the factory's refusals; a tiny run trains, evaluates and
// resumes.
#include "tests/rl/rl_fixture.h"

#include <cmath>
#include <sstream>

#include "core/error.h"
#include "marl/agents.h"
#include "marl/algorithms.h"
#include "marl/maddpg.h"
#include "rl/algorithm.h"
#include "rl/checkpoint.h"
#include "tasks/registry.h"

using namespace bidex;

namespace {

const torch::Device kCpu(torch::kCPU);

// A tiny MADDPG configuration on a real task: 4 slots, networks of 32, warmup of 16 slot-steps.
std::string tiny(const std::string& task, std::vector<std::string> extra = {}) {
  marl::register_algorithms();
  std::vector<std::string> o = {
      "env.slots=4",          "env.threads=1",         "train.steps=64",
      "maddpg.hidden=[32]",   "maddpg.warmup_steps=16", "maddpg.batch_size=8",
      "maddpg.replay_size=64", "train.device=cpu",     "train.torch_threads=1",
      "train.save_interval=1"};
  for (auto& e : extra) o.push_back(e);
  return rl::resolve_train_yaml(rl::default_train_config("maddpg"), "maddpg", task, o);
}

const tasks::TaskSpec& spec_of(const std::string& task) { return tasks::find_task(task).spec(); }

// MADDPG through the registry's factory, as the runner makes it.
std::unique_ptr<marl::Maddpg> make(const std::string& yaml, int64_t nslot) {
  const rl::TrainConfig c = rl::parse_train_config(yaml, "tiny");
  const auto& spec = spec_of(c.task);
  auto a = rl::make_algorithm("maddpg", c, spec.obs.dim(), spec.act.dim(), nslot, kCpu);
  auto* m = dynamic_cast<marl::Maddpg*>(a.get());
  REQUIRE(m != nullptr);
  a.release();
  return std::unique_ptr<marl::Maddpg>(m);
}

// One step of every slot: act on `obs`, then observe a transition to new observations.
torch::Tensor step(rl::Algorithm& alg, const torch::Tensor& obs) {
  const auto a = alg.act(obs);
  rl::Transition t;
  t.obs = torch::randn_like(obs);
  t.reward = torch::randn({obs.size(0)});
  t.done = torch::zeros({obs.size(0)});
  t.final_ids = torch::empty({0}, torch::kLong);
  t.final_obs = torch::empty({0, obs.size(1)});
  alg.observe(t);
  return a;
}

std::vector<torch::Tensor> snapshot(torch::nn::Module& m) {
  std::vector<torch::Tensor> out;
  for (auto& p : m.parameters()) out.push_back(p.detach().clone());
  return out;
}

bool same(torch::nn::Module& m, const std::vector<torch::Tensor>& before) {
  auto now = m.parameters();
  for (size_t i = 0; i < now.size(); ++i)
    if (!now[i].equal(before[i])) return false;
  return true;
}

void set(torch::nn::Module& m, const std::string& name, const torch::Tensor& value) {
  torch::NoGradGuard ng;
  auto p = m.named_parameters();
  REQUIRE(p.find(name) != nullptr);
  p[name].copy_(value);
}

}  // namespace

TEST_CASE("MADDPG's critic target and joint action match hand-worked values", "[marl][maddpg]") {
  // r + gamma (1 - terminal) q': 1 + 0.5 x 3 = 2.5; a terminal row keeps its reward 2
  const auto y = marl::maddpg_q_target(torch::tensor({1.0, 2.0}), torch::tensor({0.0, 1.0}),
                                       torch::tensor({3.0, 5.0}), 0.5);
  CHECK(y[0].item<float>() == Approx(2.5));
  CHECK(y[1].item<float>() == Approx(2.0));

  // three observation and three action columns: agent a sees obs 0 and 2 and sets action 1,
  // agent b sees obs 1 and sets actions 0 and 2
  marl::AgentSplit split;
  split.kind = "custom";
  split.obs_dim = 3;
  split.act_dim = 3;
  split.agents = {{"a", {0, 2}, {1}, {}, {}}, {"b", {1}, {0, 2}, {}, {}}};
  const marl::AgentViews views(split, kCpu);
  // agent b's step: its columns (0, 2) from its actor, agent a's (1) from the batch
  const auto batch = torch::tensor({10.f, 11.f, 12.f}).view({1, 3});
  auto own = torch::tensor({-1.f, -2.f}).view({1, 2}).set_requires_grad(true);
  const auto joint = marl::maddpg_joint_action(views, batch, 1, own);
  CHECK(joint.equal(torch::tensor({-1.f, 11.f, -2.f}).view({1, 3})));
  (joint * torch::tensor({1.f, 2.f, 3.f})).sum().backward();
  CHECK(own.grad().equal(torch::tensor({1.f, 3.f}).view({1, 2})));

  // the target through the networks: linear networks (no hidden layer, no LayerNorm) set by
  // hand. Target actor a: tanh(obs0) on action 1; target actor b: (tanh(obs1), -tanh(obs1)) on
  // actions 0 and 2; target critic: obs0 + a0 + 2 a1 + 3 a2 + 0.5.
  marl::MaddpgConfig c;
  c.net.hidden = {};
  c.net.feature_norm = false;
  c.gamma = 0.5;
  marl::Maddpg alg(c, split, 0, kCpu);
  set(*alg.target_actor(0), "action.weight", torch::tensor({1.f, 0.f}).view({1, 2}));
  set(*alg.target_actor(0), "action.bias", torch::zeros({1}));
  set(*alg.target_actor(1), "action.weight", torch::tensor({1.f, -1.f}).view({2, 1}));
  set(*alg.target_actor(1), "action.bias", torch::zeros({2}));
  set(*alg.target_critic(), "value.weight",
      torch::tensor({1.f, 0.f, 0.f, 1.f, 2.f, 3.f}).view({1, 6}));
  set(*alg.target_critic(), "value.bias", torch::tensor({0.5f}));
  rl::ReplayBuffer::Batch b;
  b.obs = torch::randn({2, 3});  // the learned networks' side: not in the target
  b.actions = torch::rand({2, 3});
  b.next_obs = torch::tensor({0.2f, 0.4f, 9.f, 0.2f, 0.4f, 9.f}).view({2, 3});
  b.rewards = torch::tensor({1.f, 1.f});
  b.terminal = torch::tensor({0.f, 1.f});
  // a0 = tanh 0.4, a1 = tanh 0.2, a2 = -tanh 0.4: q' = 0.2 + 2 tanh 0.2 - 2 tanh 0.4 + 0.5
  const double qn = 0.2 + 2 * std::tanh(0.2) - 2 * std::tanh(0.4) + 0.5;
  const auto target = alg.critic_target(b);
  CHECK(target[0].item<float>() == Approx(1 + 0.5 * qn).epsilon(1e-5));
  CHECK(target[1].item<float>() == Approx(1.0));
}

TEST_CASE("a MADDPG actor step moves only its agent's actor and raises Q of the batch",
          "[marl][maddpg]") {
  torch::manual_seed(3);
  auto alg = make(tiny("hand_over"), 4);
  const auto& spec = spec_of("hand_over");
  REQUIRE(alg->views().count() == 2);
  rl::ReplayBuffer::Batch b;
  b.obs = torch::randn({64, spec.obs.dim()});
  b.actions = torch::rand({64, spec.act.dim()}) * 2 - 1;
  for (int64_t i = 0; i < 2; ++i) {
    INFO("agent " << i);
    const int64_t other = 1 - i;
    const auto mine = snapshot(*alg->agent_actor(i));
    const auto theirs = snapshot(*alg->agent_actor(other));
    const auto critic = snapshot(*alg->critic_net());
    auto q_of_batch = [&] {
      torch::NoGradGuard ng;
      const auto own = alg->agent_actor(i)->forward(alg->views().obs(b.obs, i));
      return alg->q(b.obs, marl::maddpg_joint_action(alg->views(), b.actions, i, own))
          .mean()
          .item<double>();
    };
    const double before = q_of_batch();
    for (int k = 0; k < 3; ++k) alg->actor_step(i, b);
    CHECK_FALSE(same(*alg->agent_actor(i), mine));
    CHECK(same(*alg->agent_actor(other), theirs));
    CHECK(same(*alg->critic_net(), critic));
    CHECK(q_of_batch() > before);
  }
}

TEST_CASE("MADDPG acts uniformly at random while warming up, then with its actors' actions",
          "[marl][maddpg]") {
  torch::manual_seed(5);
  const auto& spec = spec_of("hand_over");
  const int64_t D = spec.obs.dim(), A = spec.act.dim();
  SECTION("warmup: uniform in [-1, 1], no actor involved, no update") {
    auto alg = make(tiny("hand_over", {"maddpg.replay_size=512"}), 512);
    // actors that could only give NaN: the warmup's actions never see them
    for (int64_t i = 0; i < 2; ++i) {
      torch::NoGradGuard ng;
      for (auto& p : alg->agent_actor(i)->parameters()) p.fill_(NAN);
    }
    const auto obs = torch::randn({512, D});
    const auto a = alg->act(obs);
    REQUIRE(a.sizes() == torch::IntArrayRef({512, A}));
    CHECK(a.isfinite().all().item<bool>());
    CHECK(a.min().item<float>() >= -1.f);
    CHECK(a.max().item<float>() <= 1.f);
    CHECK(a.min().item<float>() < -0.99f);
    CHECK(a.max().item<float>() > 0.99f);
    CHECK(std::abs(a.mean().item<float>()) < 0.02f);
    CHECK(a.std().item<float>() == Approx(1 / std::sqrt(3.0)).epsilon(0.02));
    CHECK_FALSE(alg->act(obs).equal(a));  // drawn afresh, not a function of obs
  }
  SECTION("after warmup: each agent's actor in its columns, plus the exploration noise") {
    auto alg = make(tiny("hand_over", {"maddpg.expl_noise=0"}), 4);
    const auto critic = snapshot(*alg->critic_net());
    // 2 steps of 4 slots: 8 rows (a batch), warmup (16) not over: the update does nothing
    for (int k = 0; k < 2; ++k) step(*alg, torch::randn({4, D}));
    CHECK(alg->warming_up());
    CHECK(alg->update(torch::Tensor()) == std::vector<double>{0, 0, 0, 8});
    CHECK(same(*alg->critic_net(), critic));
    for (int k = 0; k < 2; ++k) step(*alg, torch::randn({4, D}));
    CHECK(alg->collected() == 16);
    CHECK_FALSE(alg->warming_up());
    const auto obs = torch::randn({4, D});
    const auto a = alg->act(obs);
    for (int64_t i = 0; i < 2; ++i) {
      const auto own = alg->agent_actor(i)->forward(alg->views().obs(obs, i));
      CHECK(alg->views().actions(a, i).equal(own));
    }
    // every action column belongs to one agent: the assembled rows are the deterministic actor's
    CHECK(a.equal(alg->actor(obs)));
    CHECK(alg->sample_actor(obs).equal(a));
    // now the update learns: the critic moves and the metrics are finite
    const auto m = alg->update(torch::Tensor());
    REQUIRE(m.size() == alg->metric_names().size());
    CHECK_FALSE(same(*alg->critic_net(), critic));
    CHECK(m[0] > 0);
    for (double v : m) CHECK(std::isfinite(v));
    CHECK(m[3] == 16);
  }
  SECTION("after warmup with noise: the actors' actions plus N(0, expl_noise), clamped") {
    auto alg = make(tiny("hand_over", {"maddpg.warmup_steps=0", "maddpg.replay_size=2048"}),
                     2048);
    const auto obs = torch::randn({2048, D});
    const auto noise = alg->act(obs) - alg->actor(obs);
    CHECK(noise.abs().max().item<float>() <= 2.f);
    CHECK(noise.std().item<float>() == Approx(0.1).epsilon(0.05));
    CHECK(std::abs(noise.mean().item<float>()) < 0.005f);
  }
}

TEST_CASE("MADDPG checkpoints load into a fresh algorithm, and another split or width is refused",
          "[marl][maddpg]") {
  torch::manual_seed(7);
  const auto& spec = spec_of("hand_over");
  const int64_t D = spec.obs.dim();
  auto alg = make(tiny("hand_over"), 4);
  for (int k = 0; k < 4; ++k) step(*alg, torch::randn({4, D}));
  alg->update(torch::Tensor());  // learned a little: not the initial networks
  torch::serialize::OutputArchive out;
  alg->save(out);
  std::stringstream bytes;
  out.save_to(bytes);
  const std::string path = "runs/x/checkpoints/update_00000001.ckpt";
  auto archive = [&] {
    torch::serialize::InputArchive in;
    std::stringstream s(bytes.str());
    in.load_from(s);
    return in;
  };
  const auto obs = torch::randn({6, D});
  const auto expected = alg->actor(obs);
  SECTION("load and load_actor act identically") {
    auto fresh = make(tiny("hand_over"), 4);
    CHECK_FALSE(fresh->actor(obs).equal(expected));
    auto in = archive();
    fresh->load(in, path);
    CHECK(fresh->actor(obs).equal(expected));
    CHECK(fresh->collected() == 16);  // warmup's count came along
    CHECK_FALSE(fresh->warming_up());
    for (int64_t i = 0; i < 2; ++i)
      CHECK(same(*fresh->target_actor(i), snapshot(*alg->target_actor(i))));
    CHECK(same(*fresh->target_critic(), snapshot(*alg->target_critic())));
    auto player = make(tiny("hand_over"), 0);
    auto in2 = archive();
    player->load_actor(in2, path);
    CHECK(player->actor(obs).equal(expected));
  }
  SECTION("a checkpoint of the hand split is refused by a finger run, naming the file") {
    auto finger = make(tiny("hand_over", {"maddpg.agents=finger"}), 4);
    REQUIRE(finger->views().count() == 12);
    auto in = archive();
    CHECK_THROWS_WITH(finger->load(in, path),
                      Catch::Contains(path) && Catch::Contains("2 agents") &&
                          Catch::Contains("12 agents"));
    auto player = make(tiny("hand_over", {"maddpg.agents=finger"}), 0);
    auto in2 = archive();
    CHECK_THROWS_WITH(player->load_actor(in2, path),
                      Catch::Contains(path) && Catch::Contains("2 agents"));
  }
  SECTION("a checkpoint of other widths is refused, naming the file") {
    // (a fresh algorithm each: a refused load may have left the networks half read)
    auto wide = make(tiny("hand_over", {"maddpg.hidden=[48]"}), 4);
    auto in = archive();
    CHECK_THROWS_WITH(wide->load(in, path), Catch::Contains(path) && Catch::Contains("actors"));
    auto player = make(tiny("hand_over", {"maddpg.hidden=[48]"}), 0);
    auto in2 = archive();
    CHECK_THROWS_WITH(player->load_actor(in2, path),
                      Catch::Contains(path) && Catch::Contains("actors"));
  }
}

TEST_CASE("MADDPG's factory refuses a small buffer and rows its agents do not cover",
          "[marl][maddpg]") {
  const rl::TrainConfig c =
      rl::parse_train_config(tiny("hand_over", {"maddpg.replay_size=8"}), "tiny");
  const auto& spec = spec_of("hand_over");
  try {
    rl::make_algorithm("maddpg", c, spec.obs.dim(), spec.act.dim(), 16, kCpu);
    FAIL("a buffer smaller than one step of every slot");
  } catch (const ConfigError& e) {
    CHECK(e.key() == "maddpg.replay_size");
    CHECK_THAT(e.what(), Catch::Contains("at least env.slots (16)"));
  }
  try {
    rl::make_algorithm("maddpg", c, spec.obs.dim() + 1, spec.act.dim(), 4, kCpu);
    FAIL("rows wider than the task's");
  } catch (const Error& e) {
    CHECK_THAT(e.what(), Catch::Contains(std::to_string(spec.obs.dim())) &&
                             Catch::Contains(std::to_string(spec.obs.dim() + 1)));
  }
  CHECK_THROWS_AS(
      make(tiny("hand_over", {"maddpg.batch_size=128", "maddpg.replay_size=64"}), 4),
      ConfigError);
}

TEST_CASE("a tiny MADDPG run trains, evaluates and resumes", "[marl][maddpg]") {
  torch::manual_seed(1);
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("maddpg");
  auto opt = test::quiet();
  opt.stop_after_updates = 1;
  auto r = rl::train_new(tiny("catch_underarm_raise"), dir, opt);
  CHECK(r.updates == 1);
  CHECK(rl::read_checkpoint_meta(rl::list_checkpoints(dir).back()).algo == "maddpg");
  rl::LoadedPolicy p(dir);
  const auto e = rl::evaluate(p, 4, 3, 1);
  CHECK(e.episodes == 4);
  CHECK(std::isfinite(e.mean_return));
  r = rl::train_resume(dir, test::quiet());
  CHECK(r.updates == 2);
  CHECK(r.steps == 64);
  const std::string csv = read_file(dir + "/metrics.csv");
  for (const char* col : {"critic_loss", "actor_loss", "q_mean", "replay_size"})
    CHECK(csv.find(col) != std::string::npos);
}
