#include "bench/pack_bench.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <type_traits>
#include <vector>

#include "bench/sim_bench.h"
#include "core/error.h"
#include "core/progress.h"
#include "taskpack/pack.h"
#include "taskpack/suite.h"
#include "taskpack/warp_pack.h"
#include "tasks/env.h"

namespace bidex::bench {

using nlohmann::json;

namespace {

struct Rate {
  double slot_steps_per_s = 0;
  int64_t steps = 0, episodes = 0;
  double seconds = 0;
  double launch_seconds = -1;  // GPU: host seconds spent queueing the timed steps
};

// Steps `pack` with random actions until min_seconds of timed stepping; actions are drawn
// outside the timed part (on the host for the CPU pack, on the device for the GPU pack).
template <class P>
Rate measure(P& pack, const PackBenchConfig& cfg, std::mt19937_64& rng) {
  std::vector<float> a(static_cast<size_t>(pack.nslot()) * pack.act_dim());
  int64_t drawn = 0;
  auto draw = [&] {
    if constexpr (std::is_same_v<P, taskpack::WarpPack>) {
      sim::WarpBackend& home = pack.group(0).backend();
      home.random_fill("pack_actions", cfg.seed, drawn++, -1.f, 1.f);
      home.synchronize();
    } else {
      tasks::random_actions(a, rng);
    }
  };
  auto step = [&] {
    if constexpr (std::is_same_v<P, taskpack::WarpPack>)
      pack.step();
    else
      pack.step(a);
  };
  for (int i = 0; i < cfg.warmup_steps; ++i) {
    draw();
    step();
  }
  pack.take_stats();
  Rate r;
  double launched = 0;
  if constexpr (std::is_same_v<P, taskpack::WarpPack>) launched = pack.launch_seconds();
  while (r.seconds < cfg.min_seconds) {
    draw();
    auto t0 = std::chrono::steady_clock::now();
    step();
    r.seconds += seconds_since(t0);
    ++r.steps;
  }
  if constexpr (std::is_same_v<P, taskpack::WarpPack>)
    r.launch_seconds = pack.launch_seconds() - launched;
  for (auto& st : pack.take_stats()) r.episodes += st.episodes;
  r.slot_steps_per_s = static_cast<double>(r.steps) * pack.nslot() / r.seconds;
  return r;
}

// A measurement of a fresh pack of `spec` on the configured device.
Rate measure_pack(const taskpack::PackSpec& spec, const PackBenchConfig& cfg,
                  std::mt19937_64& rng, int* threads, bool share_scenes = true) {
  if (cfg.device == "cuda") {
    taskpack::WarpPackOptions wo;
    wo.seed = cfg.seed;
    wo.share_scenes = share_scenes;
    taskpack::WarpPack pack(spec, wo);
    *threads = pack.threads();
    return measure(pack, cfg, rng);
  }
  taskpack::PackOptions po;
  po.threads = cfg.threads;
  po.seed = cfg.seed;
  taskpack::TaskPack pack(spec, po);
  *threads = pack.threads();
  return measure(pack, cfg, rng);
}

json rate_json(const Rate& r) {
  json j = {{"slot_steps_per_s", r.slot_steps_per_s},
            {"steps", r.steps},
            {"seconds", r.seconds},
            {"episodes", r.episodes}};
  if (r.launch_seconds >= 0) j["host_launch_seconds"] = r.launch_seconds;
  return j;
}

}  // namespace

json run_pack_bench(const PackBenchConfig& cfg) {
  const taskpack::Suite suite = taskpack::load_suite(cfg.suite);
  const taskpack::PackSpec packed = taskpack::suite_pack(suite, "train", cfg.slots);
  const int n = static_cast<int>(packed.entries.size());
  std::mt19937_64 rng(cfg.seed);
  if (cfg.device != "cpu" && cfg.device != "cuda")
    throw ConfigError("", "--device", "cpu or cuda", cfg.device);
  // on the GPU, the pack also with one backend per scene (WarpPackOptions::share_scenes off)
  const bool separate = cfg.device == "cuda";
  Progress bar("bench pack " + suite.id, int64_t(cfg.rounds) * (n + 1 + separate),
               "measurements");
  int64_t done = 0;

  Rate best_packed, best_separate;
  std::vector<Rate> best_single(n);
  int threads = 0;
  for (int round = 0; round < cfg.rounds; ++round) {
    {
      Rate r = measure_pack(packed, cfg, rng, &threads);
      if (r.slot_steps_per_s > best_packed.slot_steps_per_s) best_packed = r;
      std::fprintf(stderr, "%s packed, %d slots: %.0f slot-steps/s\n", suite.id.c_str(),
                   cfg.slots, r.slot_steps_per_s);
      if (cfg.progress) bar.update(++done);
    }
    if (separate) {
      int unused = 0;
      Rate r = measure_pack(packed, cfg, rng, &unused, /*share_scenes=*/false);
      if (r.slot_steps_per_s > best_separate.slot_steps_per_s) best_separate = r;
      std::fprintf(stderr, "%s packed, one backend per scene, %d slots: %.0f slot-steps/s\n",
                   suite.id.c_str(), cfg.slots, r.slot_steps_per_s);
      if (cfg.progress) bar.update(++done);
    }
    for (int g = 0; g < n; ++g) {
      // the task alone: a one-entry plain pack of the same entry (same task YAML) at all slots
      taskpack::PackSpec one;
      one.name = packed.entries[g].task;
      one.entries = {packed.entries[g]};
      one.entries[0].slots = cfg.slots;
      one.entries[0].reward_scale = 1.0;
      int unused = 0;
      Rate r = measure_pack(one, cfg, rng, &unused);
      if (r.slot_steps_per_s > best_single[g].slot_steps_per_s) best_single[g] = r;
      std::fprintf(stderr, "%s alone, %d slots: %.0f slot-steps/s\n",
                   packed.entries[g].task.c_str(), cfg.slots, r.slot_steps_per_s);
      if (cfg.progress) bar.update(++done);
    }
  }
  if (cfg.progress) bar.finish();

  const char* connections = std::getenv("CUDA_DEVICE_MAX_CONNECTIONS");
  json singles = json::array();
  double mean = 0, inv = 0;
  for (int g = 0; g < n; ++g) {
    const Rate& r = best_single[g];
    mean += r.slot_steps_per_s / n;
    inv += 1.0 / r.slot_steps_per_s / n;
    json one = rate_json(r);
    one["task"] = packed.entries[g].task;
    one["label"] = packed.entries[g].label;
    singles.push_back(one);
  }
  json slots_per_task = json::array();
  for (auto& e : packed.entries) slots_per_task.push_back(e.slots);
  json out = {{"benchmark", "pack"},
          {"what", "slot-steps/s of the suite's train split packed in one instance, against "
                   "each of its tasks alone at the same slot count, random actions, the best of "
                   "`rounds` alternating measurements each"},
          {"suite", suite.id},
          {"slots", cfg.slots},
          {"slots_per_task", slots_per_task},
          {"device", cfg.device == "cuda"
                         ? "cuda (MuJoCo Warp: scenes of one topology share a backend, one "
                           "stream per backend)"
                         : "cpu"},
          {"threads", threads},
          {"rounds", cfg.rounds},
          {"min_seconds", cfg.min_seconds},
          {"cuda_device_max_connections", connections ? connections : "unset (8)"},
          {"packed", rate_json(best_packed)},
          {"single", singles},
          {"mean_single_slot_steps_per_s", mean},
          {"harmonic_mean_single_slot_steps_per_s", 1.0 / inv},
          {"packed_over_mean_single", best_packed.slot_steps_per_s / mean},
          {"target", "packed_over_mean_single >= 0.8"}};
  if (separate) {
    out["packed_one_backend_per_scene"] = rate_json(best_separate);
    out["one_backend_per_scene_over_mean_single"] = best_separate.slot_steps_per_s / mean;
  }
  return out;
}

}  // namespace bidex::bench
