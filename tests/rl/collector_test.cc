// rl/collector: one step of a real pack hands back its observations, rewards and done flags, and
// exactly the time-limited slots' final observations for bootstrapping.
#include "tests/rl/rl_fixture.h"

#include "rl/collector.h"
#include "taskpack/pack.h"

using namespace bidex;

TEST_CASE("the collector hands back each step and the time-limited slots' final observations",
          "[rl][collector]") {
  // catch_underarm_raise: 40-step episodes; zero actions keep the egg on the palm, so every
  // slot is cut by the time limit at step 40 and none before
  taskpack::PackSpec spec;
  spec.name = "one";
  taskpack::PackEntry e;
  e.task = e.label = "catch_underarm_raise";
  e.slots = 3;
  spec.entries.push_back(e);
  taskpack::PackOptions po;
  po.threads = 1;
  po.seed = 5;
  taskpack::TaskPack pack(spec, po);
  auto collector_ptr = rl::make_collector(pack, torch::Device(torch::kCPU));
  rl::Collector& collector = *collector_ptr;
  const int N = pack.nslot(), D = pack.obs_dim();

  torch::Tensor obs = collector.reset();
  REQUIRE(obs.sizes() == torch::IntArrayRef({N, D}));
  CHECK(obs[1][7].item<float>() == pack.obs[size_t(1) * D + 7]);
  const auto zero = torch::zeros({N, pack.act_dim()});
  for (int step = 1; step <= 40; ++step) {
    const rl::Transition t = collector.step(zero);
    REQUIRE(t.obs.sizes() == torch::IntArrayRef({N, D}));
    for (int s = 0; s < N; ++s) {
      CHECK(t.reward[s].item<float>() == pack.reward[s]);
      CHECK(t.obs[s][D - 1].item<float>() == pack.obs[size_t(s) * D + D - 1]);
    }
    if (step < 40) {
      CHECK(t.done.sum().item<float>() == 0.f);
      CHECK(t.final_ids.numel() == 0);
    } else {
      CHECK(t.done.sum().item<float>() == float(N));
      REQUIRE(t.final_ids.numel() == N);
      REQUIRE(t.final_obs.sizes() == torch::IntArrayRef({N, D}));
      for (int j = 0; j < N; ++j) {
        const int64_t s = t.final_ids[j].item<int64_t>();
        CHECK(s == j);
        for (int k : {0, 5, D - 1})
          CHECK(t.final_obs[j][k].item<float>() == pack.final_obs[size_t(s) * D + k]);
        // the slot goes on from its reset state, not from the final one
        CHECK(t.obs[s].equal(t.final_obs[j]) == false);
      }
    }
  }
  CHECK(collector.take_sim_seconds() > 0);
  CHECK(collector.take_sim_seconds() == 0);
}
