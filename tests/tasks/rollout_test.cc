// tasks/env rollouts of every task under random actions: finite results at two batch sizes,
// and bitwise determinism (same seed -> same trajectories for 1 and 2 threads, across runs and
// batch sizes; another seed differs).
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

namespace {

// Every result buffer of every step, in order, as bytes (for bitwise comparisons).
struct Trajectory {
  std::vector<unsigned char> bytes;
  int resets = 0;  // episodes that ended inside the run
  template <class T>
  void add(const std::vector<T>& v, size_t first, size_t count) {
    const auto* p = reinterpret_cast<const unsigned char*>(v.data() + first);
    bytes.insert(bytes.end(), p, p + count * sizeof(T));
  }
};

// `nslot` slots of task `id`, recording the first `record` of them. Each step draws actions
// for `total` slots from one stream and gives the env the first nslot rows, so batches of
// different sizes see the same actions in the same slots.
Trajectory run(const std::string& id, int nslot, int record, int total, int steps, uint64_t seed,
               int threads) {
  auto env = make_env(id, nslot, seed, threads);
  REQUIRE(env->threads() == threads);
  std::mt19937_64 rng(1234);
  const size_t ad = env->act_dim(), od = env->obs_dim(), nt = env->nterms();
  std::vector<float> all(static_cast<size_t>(total) * ad);
  Trajectory t;
  t.add(env->obs, 0, record * od);
  for (int i = 0; i < steps; ++i) {
    random_actions(all, rng);
    env->step(all.data());
    for (int s = 0; s < record; ++s) {
      t.add(env->obs, s * od, od);
      t.add(env->reward, s, 1);
      t.add(env->terms, s * nt, nt);
      t.add(env->terminated, s, 1);
      t.add(env->truncated, s, 1);
      t.add(env->success, s, 1);
      t.add(env->fault, s, 1);
      if (env->terminated[s] || env->truncated[s]) {
        t.add(env->final_obs, s * od, od);
        t.resets += 1;
      }
    }
  }
  return t;
}

}  // namespace

TEST_CASE("random actions give finite results for every task at 3 and 16 slots",
          "[tasks][rollout]") {
  for (const char* id : kTaskIds) {
    for (auto [nslot, steps] : {std::pair{3, 300}, std::pair{16, 80}}) {
      INFO("task " << id << ", " << nslot << " slots, " << steps << " steps");
      auto env = make_env(id, nslot, 41);
      std::mt19937_64 rng(42);
      std::vector<float> a(static_cast<size_t>(nslot) * env->act_dim());
      int64_t bad = 0, out_of_range = 0, sum_mismatch = 0, episodes = 0;
      for (int i = 0; i < steps; ++i) {
        random_actions(a, rng);
        env->step(a);
        for (float x : env->obs) {
          bad += !std::isfinite(x);
          out_of_range += std::abs(x) > 5.f;
        }
        for (float x : env->final_obs) bad += !std::isfinite(x);
        for (float x : env->terms) bad += !std::isfinite(x);
        for (int s = 0; s < nslot; ++s) {
          bad += !std::isfinite(env->reward[s]);
          double sum = 0;
          for (int k = 0; k < env->nterms(); ++k) sum += env->terms[static_cast<size_t>(s) * env->nterms() + k];
          sum_mismatch += std::abs(sum - env->reward[s]) > 1e-5 * (1 + std::abs(sum));
          // the pose terms are in (0, 1]
          for (int k = 0; k < env->nterms(); ++k) {
            const std::string& n = env->spec().reward_terms[k].name;
            const float x = env->terms[static_cast<size_t>(s) * env->nterms() + k];
            if (n.rfind("pose", 0) == 0 && !env->fault[s]) bad += !(x > 0.f && x <= 1.f);
          }
        }
        episodes += env->take_stats().episodes;
      }
      CHECK(bad == 0);
      CHECK(out_of_range == 0);
      CHECK(sum_mismatch == 0);
      CHECK(episodes > 0);  // episodes ended and restarted under the random actions
    }
  }
}

TEST_CASE("same seed gives bitwise identical trajectories for 1 and 2 threads and across runs",
          "[tasks][determinism]") {
  for (const char* id : kTaskIds) {
    INFO("task " << id);
    const int nslot = 4, steps = 80;  // past the 75-step time limit
    const Trajectory one = run(id, nslot, nslot, nslot, steps, 5, 1);
    const Trajectory two = run(id, nslot, nslot, nslot, steps, 5, 2);
    const Trajectory again = run(id, nslot, nslot, nslot, steps, 5, 2);
    CHECK(one.resets > 0);  // in-step resets are part of what is compared
    REQUIRE(one.bytes.size() == two.bytes.size());
    CHECK(std::memcmp(one.bytes.data(), two.bytes.data(), one.bytes.size()) == 0);
    REQUIRE(two.bytes.size() == again.bytes.size());
    CHECK(std::memcmp(two.bytes.data(), again.bytes.data(), two.bytes.size()) == 0);
    // another seed: other reset samples, so other observations
    const Trajectory other = run(id, nslot, nslot, nslot, 2, 6, 2);
    const Trajectory first = run(id, nslot, nslot, nslot, 2, 5, 2);
    REQUIRE(other.bytes.size() == first.bytes.size());
    CHECK(std::memcmp(other.bytes.data(), first.bytes.data(), other.bytes.size()) != 0);
  }
}

TEST_CASE("a slot's trajectory does not depend on the batch size", "[tasks][determinism]") {
  for (const char* id : {"catch_abreast", "catch_over2underarm"}) {
    INFO("task " << id);
    // the first 2 slots of a 5-slot batch replay exactly as a 2-slot batch
    const Trajectory small = run(id, 2, 2, 5, 60, 9, 2);
    const Trajectory big = run(id, 5, 2, 5, 60, 9, 2);
    CHECK(small.resets > 0);
    CHECK(small.resets == big.resets);
    REQUIRE(small.bytes.size() == big.bytes.size());
    CHECK(std::memcmp(small.bytes.data(), big.bytes.data(), small.bytes.size()) == 0);
  }
}
