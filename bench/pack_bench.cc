#include "bench/pack_bench.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <vector>

#include "bench/sim_bench.h"
#include "core/progress.h"
#include "taskpack/pack.h"
#include "taskpack/suite.h"
#include "tasks/env.h"

namespace bidex::bench {

using nlohmann::json;

namespace {

struct Rate {
  double slot_steps_per_s = 0;
  int64_t steps = 0, episodes = 0;
  double seconds = 0;
};

// Steps `pack` with random actions until min_seconds of timed stepping; actions are drawn
// outside the timed part.
Rate measure(taskpack::TaskPack& pack, const PackBenchConfig& cfg, std::mt19937_64& rng) {
  std::vector<float> a(static_cast<size_t>(pack.nslot()) * pack.act_dim());
  for (int i = 0; i < cfg.warmup_steps; ++i) {
    tasks::random_actions(a, rng);
    pack.step(a);
  }
  pack.take_stats();
  Rate r;
  while (r.seconds < cfg.min_seconds) {
    tasks::random_actions(a, rng);
    auto t0 = std::chrono::steady_clock::now();
    pack.step(a);
    r.seconds += seconds_since(t0);
    ++r.steps;
  }
  for (auto& st : pack.take_stats()) r.episodes += st.episodes;
  r.slot_steps_per_s = static_cast<double>(r.steps) * pack.nslot() / r.seconds;
  return r;
}

}  // namespace

json run_pack_bench(const PackBenchConfig& cfg) {
  const taskpack::Suite suite = taskpack::load_suite(cfg.suite);
  const taskpack::PackSpec packed = taskpack::suite_pack(suite, "train", cfg.slots);
  const int n = static_cast<int>(packed.entries.size());
  std::mt19937_64 rng(cfg.seed);
  taskpack::PackOptions po;
  po.threads = cfg.threads;
  po.seed = cfg.seed;
  Progress bar("bench pack " + suite.id, int64_t(cfg.rounds) * (n + 1), "measurements");
  int64_t done = 0;

  Rate best_packed;
  std::vector<Rate> best_single(n);
  int threads = 0;
  for (int round = 0; round < cfg.rounds; ++round) {
    {
      taskpack::TaskPack pack(packed, po);
      threads = pack.threads();
      Rate r = measure(pack, cfg, rng);
      if (r.slot_steps_per_s > best_packed.slot_steps_per_s) best_packed = r;
      std::fprintf(stderr, "%s packed, %d slots: %.0f slot-steps/s\n", suite.id.c_str(),
                   cfg.slots, r.slot_steps_per_s);
      if (cfg.progress) bar.update(++done);
    }
    for (int g = 0; g < n; ++g) {
      // the task alone: a one-entry plain pack of the same entry (same task YAML) at all slots
      taskpack::PackSpec one;
      one.name = packed.entries[g].task;
      one.entries = {packed.entries[g]};
      one.entries[0].slots = cfg.slots;
      one.entries[0].reward_scale = 1.0;
      taskpack::TaskPack alone(one, po);
      Rate r = measure(alone, cfg, rng);
      if (r.slot_steps_per_s > best_single[g].slot_steps_per_s) best_single[g] = r;
      std::fprintf(stderr, "%s alone, %d slots: %.0f slot-steps/s\n",
                   packed.entries[g].task.c_str(), cfg.slots, r.slot_steps_per_s);
      if (cfg.progress) bar.update(++done);
    }
  }
  if (cfg.progress) bar.finish();

  json singles = json::array();
  double mean = 0, inv = 0;
  for (int g = 0; g < n; ++g) {
    const Rate& r = best_single[g];
    mean += r.slot_steps_per_s / n;
    inv += 1.0 / r.slot_steps_per_s / n;
    singles.push_back({{"task", packed.entries[g].task},
                       {"label", packed.entries[g].label},
                       {"slot_steps_per_s", r.slot_steps_per_s},
                       {"steps", r.steps},
                       {"seconds", r.seconds},
                       {"episodes", r.episodes}});
  }
  json slots_per_task = json::array();
  for (auto& e : packed.entries) slots_per_task.push_back(e.slots);
  return {{"benchmark", "pack"},
          {"what", "slot-steps/s of the suite's train split packed in one instance, against "
                   "each of its tasks alone at the same slot count, random actions, the best of "
                   "`rounds` alternating measurements each"},
          {"suite", suite.id},
          {"slots", cfg.slots},
          {"slots_per_task", slots_per_task},
          {"threads", threads},
          {"rounds", cfg.rounds},
          {"min_seconds", cfg.min_seconds},
          {"packed", {{"slot_steps_per_s", best_packed.slot_steps_per_s},
                      {"steps", best_packed.steps},
                      {"seconds", best_packed.seconds},
                      {"episodes", best_packed.episodes}}},
          {"single", singles},
          {"mean_single_slot_steps_per_s", mean},
          {"harmonic_mean_single_slot_steps_per_s", 1.0 / inv},
          {"packed_over_mean_single", best_packed.slot_steps_per_s / mean},
          {"target", "packed_over_mean_single >= 0.8"}};
}

}  // namespace bidex::bench
