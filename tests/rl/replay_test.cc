// rl/replay: the ring buffer keeps the newest rows, pairs each row's fields, turns a collector
// transition into bootstrap-correct rows, and samples stored rows uniformly.
#include "tests/rl/rl_fixture.h"

#include "core/error.h"
#include "rl/replay.h"

using namespace bidex;

namespace {

// n rows of a step whose every field encodes its row id `first + i`
struct Step {
  torch::Tensor obs, act, rew, next, term;
};
Step step_of(int64_t first, int64_t n, int64_t D = 3, int64_t A = 2) {
  auto id = torch::arange(first, first + n, torch::kFloat32);
  return {id.unsqueeze(1).repeat({1, D}), -id.unsqueeze(1).repeat({1, A}), 10 * id,
          id.unsqueeze(1).repeat({1, D}) + 0.5, torch::fmod(id, 2)};
}

}  // namespace

TEST_CASE("the replay buffer keeps the newest rows, each with its own fields", "[rl][replay]") {
  rl::ReplayBuffer rb(10, 3, 2, torch::Device(torch::kCPU));
  CHECK(rb.size() == 0);
  CHECK_THROWS_WITH(rb.sample(1), Catch::Contains("empty"));
  for (int k = 0; k < 3; ++k) {  // 3 steps of 4 slots: ids 0..11, 0 and 1 overwritten
    Step s = step_of(4 * k, 4);
    rb.add(s.obs, s.act, s.rew, s.next, s.term);
  }
  CHECK(rb.size() == 10);
  CHECK(rb.capacity() == 10);
  torch::manual_seed(3);
  const auto b = rb.sample(4000);
  REQUIRE(b.obs.sizes() == torch::IntArrayRef({4000, 3}));
  const auto id = b.obs.select(1, 0);
  // every field of a sampled row belongs to the same stored step
  CHECK(torch::equal(b.obs.select(1, 2), id));
  CHECK(torch::equal(b.actions.select(1, 1), -id));
  CHECK(torch::equal(b.rewards, 10 * id));
  CHECK(torch::equal(b.next_obs.select(1, 0), id + 0.5));
  CHECK(torch::equal(b.terminal, torch::fmod(id, 2)));
  // only the ten newest ids (2..11), each about a tenth of the time (400 expected; a binomial
  // standard deviation is 19, so 300..500 holds at more than five of them)
  CHECK(id.min().item<float>() == 2.f);
  CHECK(id.max().item<float>() == 11.f);
  const auto counts = torch::bincount(id.to(torch::kLong), {}, 12);
  for (int i = 2; i < 12; ++i) {
    INFO("id " << i);
    CHECK(counts[i].item<int64_t>() > 300);
    CHECK(counts[i].item<int64_t>() < 500);
  }
  // a step wider than the buffer is refused, naming both sizes, and changes nothing
  Step wide = step_of(100, 11);
  const std::string msg = [&] {
    try {
      rb.add(wide.obs, wide.act, wide.rew, wide.next, wide.term);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  }();
  CHECK(msg.find("11 slots") != std::string::npos);
  CHECK(msg.find("10 rows") != std::string::npos);
  CHECK(rb.sample(200).obs.max().item<float>() == 11.f);
}

TEST_CASE("a collector transition becomes rows that bootstrap only where the time limit cut",
          "[rl][replay]") {
  rl::ReplayBuffer rb(4, 2, 1, torch::Device(torch::kCPU));
  // slots 0..3: 0 goes on, 1 terminated, 2 cut by the time limit, 3 goes on
  rl::Transition t;
  t.obs = torch::tensor({{1.f, 1.f}, {2.f, 2.f}, {3.f, 3.f}, {4.f, 4.f}});  // 1, 2: reset states
  t.reward = torch::tensor({0.1f, 0.2f, 0.3f, 0.4f});
  t.done = torch::tensor({0.f, 1.f, 1.f, 0.f});
  t.final_ids = torch::tensor({2}, torch::kLong);
  t.final_obs = torch::tensor({{30.f, 30.f}});
  const auto obs = torch::zeros({4, 2});
  const auto act = torch::arange(4, torch::kFloat32).unsqueeze(1);  // action = slot
  rb.add(obs, act, t);
  REQUIRE(rb.size() == 4);
  torch::manual_seed(1);
  const auto b = rb.sample(64);
  for (int64_t i = 0; i < 64; ++i) {
    const int slot = static_cast<int>(b.actions[i][0].item<float>());
    INFO("slot " << slot);
    const float next = b.next_obs[i][0].item<float>(), term = b.terminal[i].item<float>();
    if (slot == 2) {
      CHECK(next == 30.f);  // the final observation, not the reset state
      CHECK(term == 0.f);
    } else {
      CHECK(next == float(slot + 1));
      CHECK(term == (slot == 1 ? 1.f : 0.f));
    }
    CHECK(b.rewards[i].item<float>() == Approx(0.1f * (slot + 1)));
  }
}
