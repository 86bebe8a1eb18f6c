#include "bench/warp_bench.h"

#include <chrono>
#include <cstdio>

#include "bench/sim_bench.h"
#include "core/progress.h"
#include "sim/warp_backend.h"
#include "tasks/env.h"
#include "tasks/registry.h"

namespace bidex::bench {

using nlohmann::json;

namespace {

struct Rate {
  int64_t steps = 0;
  double seconds = 0;
  double per_s() const { return seconds > 0 ? steps / seconds : 0; }
};

// Control steps per second of one pass sequence, timed from the first launch to the end of the
// stream's work.
template <class F>
Rate timed(sim::WarpBackend& w, const WarpBenchConfig& cfg, int64_t& step, F&& pass) {
  w.synchronize();
  Rate r;
  const auto t0 = std::chrono::steady_clock::now();
  do {
    for (int k = 0; k < 10; ++k, ++step, ++r.steps) {
      w.random_inputs(cfg.seed, step, cfg.max_force, cfg.max_torque);
      pass();
    }
    w.synchronize();
    r.seconds = seconds_since(t0);
  } while (r.seconds < cfg.min_seconds);
  return r;
}

}  // namespace

json run_warp_bench(const WarpBenchConfig& cfg) {
  json results = json::array();
  Progress bar("bench warp", static_cast<int64_t>(cfg.tasks.size() * cfg.worlds.size()),
               "measurements");
  int64_t done = 0;
  for (const auto& id : cfg.tasks) {
    tasks::EnvOptions eo;
    eo.nslot = 1;
    eo.physics_file = cfg.physics_file;
    tasks::TaskEnv env(tasks::make_task(id, ""), eo);  // the task's scene, compiled once
    const sim::SimModel& model = env.model();
    for (int n : cfg.worlds) {
      sim::WarpOptions o;
      o.device = cfg.device;
      o.njmax = cfg.njmax;
      o.nconmax = cfg.nconmax;
      const auto t_setup = std::chrono::steady_clock::now();
      sim::WarpBackend w(model, n, o);
      const double setup = seconds_since(t_setup);
      int64_t step = 0;
      auto bidex_step = [&] {
        w.step();
        w.reset_begin();
        w.reset_end();
      };
      auto raw_step = [&] { w.raw_step(); };
      for (int i = 0; i < cfg.warmup_steps; ++i) {
        w.random_inputs(cfg.seed, step++, cfg.max_force, cfg.max_torque);
        bidex_step();
        raw_step();
      }
      const int64_t faults0 = w.total_faults(), overflows0 = w.total_overflows();
      Rate best_raw, best_bidex;
      for (int r = 0; r < cfg.rounds; ++r) {
        Rate raw = timed(w, cfg, step, raw_step);
        Rate bx = timed(w, cfg, step, bidex_step);
        if (raw.per_s() > best_raw.per_s()) best_raw = raw;
        if (bx.per_s() > best_bidex.per_s()) best_bidex = bx;
      }
      const int substeps = model.physics().substeps;
      const double raw_slot = best_raw.per_s() * n, bidex_slot = best_bidex.per_s() * n;
      json row = {{"task", env.spec().versioned_id()},
                  {"worlds", n},
                  {"device", cfg.device},
                  {"on_gpu", w.on_gpu()},
                  {"substeps", substeps},
                  {"timestep", model.physics().timestep},
                  {"njmax", w.options().njmax},
                  {"nconmax", w.options().nconmax},
                  {"setup_seconds", setup},
                  {"raw_slot_steps_per_s", raw_slot},
                  {"raw_physics_steps_per_s", raw_slot * substeps},
                  {"bidex_slot_steps_per_s", bidex_slot},
                  {"bidex_physics_steps_per_s", bidex_slot * substeps},
                  {"ratio_bidex_to_raw", raw_slot > 0 ? bidex_slot / raw_slot : 0},
                  {"faults", w.total_faults() - faults0},
                  {"overflows", w.total_overflows() - overflows0},
                  {"device_bytes", w.device_bytes()},
                  {"device_bytes_per_world", static_cast<double>(w.device_bytes()) / n}};
      results.push_back(row);
      if (cfg.progress) bar.update(++done);
      std::fprintf(stderr, "%s, %d worlds: raw %.0f, bidex %.0f slot-steps/s (ratio %.3f)\n",
                   id.c_str(), n, raw_slot, bidex_slot, row["ratio_bidex_to_raw"].get<double>());
    }
  }
  if (cfg.progress) bar.finish();
  return {{"benchmark", "warp"},
          {"what", "control steps (substeps of physics) per second x worlds on MuJoCo Warp: raw "
                   "= the substeps of mjw.step alone; bidex = the backend's step (base forces "
                   "at the pivots every substep, fault check) plus its reset and position "
                   "passes; random inputs written on the device before each step of both; raw "
                   "and bidex alternate, the best of each kept"},
          {"results", results}};
}

}  // namespace bidex::bench
