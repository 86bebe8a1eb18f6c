#include "bench/warp_bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "bench/sim_bench.h"
#include "core/progress.h"
#include "sim/warp_backend.h"
#include "tasks/env.h"
#include "tasks/registry.h"
#include "tasks/warp_env.h"

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

// The whole task step on the GPU (random actions written on the device, then apply_actions,
// physics, evaluate, resets, observe) against raw MuJoCo Warp on the same worlds.
json task_step(const std::string& id, int n, const WarpBenchConfig& cfg) {
  tasks::WarpEnvOptions o;
  o.nslot = n;
  o.seed = cfg.seed;
  o.device = cfg.device;
  o.physics_file = cfg.physics_file;
  tasks::WarpTaskEnv env(tasks::make_task(id, ""), o);
  sim::WarpBackend& w = env.backend();
  int64_t step = 0;
  auto full = [&] {
    w.random_fill("actions", cfg.seed, step, -1.0f, 1.0f);
    env.step();
  };
  auto raw = [&] { w.raw_step(); };
  for (int i = 0; i < cfg.warmup_steps; ++i, ++step) full();
  env.take_stats();
  const int64_t physics_faults0 = w.total_faults();
  Rate best_raw, best_full;
  int64_t checked = 0;  // task slot-steps that went through the fault check
  for (int r = 0; r < cfg.rounds; ++r) {
    Rate a = timed(w, cfg, step, raw);
    // raw stepping never resets and pushes the free hands with random base forces; task steps
    // that went on from there faulted (bench/results/gpu-faults-h100), so every world starts a
    // new episode first
    env.reset();
    Rate b = timed(w, cfg, step, full);
    checked += b.steps * static_cast<int64_t>(n);
    if (a.per_s() > best_raw.per_s()) best_raw = a;
    if (b.per_s() > best_full.per_s()) best_full = b;
  }
  for (; checked < cfg.min_checked; ++step, checked += n) full();
  const auto st = env.take_stats();
  // a task fault is a physics fault (the backend's check) or a non-finite observation
  json kinds = w.fault_kinds();
  const int64_t obs_faults = st.faults - (w.total_faults() - physics_faults0);
  if (obs_faults > 0) kinds["non_finite_observation"] = obs_faults;
  const double raw_slot = best_raw.per_s() * n, full_slot = best_full.per_s() * n;
  return {{"task_slot_steps_per_s", full_slot},
          {"task_raw_slot_steps_per_s", raw_slot},
          {"task_ratio_to_raw", raw_slot > 0 ? full_slot / raw_slot : 0},
          {"task_episodes", st.episodes},
          {"task_mean_return", st.episodes ? st.return_sum / st.episodes : 0},
          {"task_checked_slot_steps", checked},
          {"task_faults", st.faults},
          {"task_fault_kinds", kinds}};
}

// Two fresh backends of the same scene stepped with the same inputs: are they bitwise equal?
// (MuJoCo Warp accumulates some sums with atomics, whose order can vary between runs.)
json determinism(const sim::SimModel& model, const WarpBenchConfig& cfg, int n, int steps) {
  std::vector<float> q[2];
  for (auto& qk : q) {
    sim::WarpOptions o;
    o.device = cfg.device;
    o.njmax = cfg.njmax;
    o.nconmax = cfg.nconmax;
    sim::WarpBackend w(model, n, o);
    for (int t = 0; t < steps; ++t) {
      w.random_inputs(cfg.seed, t, cfg.max_force, cfg.max_torque);
      w.step();
      w.reset_begin();
      w.reset_end();
    }
    qk = w.download("qpos");
  }
  double max_diff = 0;
  int64_t differing = 0;
  for (size_t i = 0; i < q[0].size(); ++i) {
    const double d = std::abs(double(q[0][i]) - double(q[1][i]));
    max_diff = std::max(max_diff, d);
    differing += q[0][i] != q[1][i];
  }
  return {{"worlds", n}, {"steps", steps}, {"bitwise_identical", differing == 0},
          {"qpos_values_differing", differing}, {"qpos_max_abs_diff", max_diff}};
}

// Where raw stepping's time goes (sim::WarpBackend::phase_profile): milliseconds per call of
// each part, and the shares of a substep taken by collision detection, the constraint rows and
// the constraint solver.
json phases(sim::WarpBackend& w, int steps) {
  const auto ms = w.phase_profile(steps);
  auto at = [&](const char* part) {
    auto it = ms.find(part);
    return it == ms.end() ? 0.0 : it->second;
  };
  const double step = at("step");
  auto share = [&](double x) { return step > 0 ? x / step : 0.0; };
  return {{"phase_ms", ms},
          {"phase_steps", steps},
          {"collision_share", share(at("collision"))},
          {"make_constraint_share", share(at("make_constraint"))},
          {"solver_share", share(std::max(0.0, at("forward") - at("forward_before_solve")))}};
}

}  // namespace

json run_warp_bench(const WarpBenchConfig& cfg) {
  json results = json::array(), determinism_rows = json::array();
  Progress bar("bench warp", static_cast<int64_t>(cfg.tasks.size() * cfg.worlds.size()),
               "measurements");
  int64_t done = 0;
  for (const auto& id : cfg.tasks) {
    // the task's scene with the GPU's physics, compiled once
    auto task = tasks::make_task(id, "");
    auto model_ptr = tasks::build_task_model(*task, "", cfg.physics_file, /*on_gpu=*/true);
    const sim::SimModel& model = *model_ptr;
    if (cfg.determinism_steps > 0) {
      json d = determinism(model, cfg, std::min(cfg.worlds.front(), 2048), cfg.determinism_steps);
      d["task"] = task->spec().versioned_id();
      determinism_rows.push_back(d);
    }
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
      int64_t checked = 0;  // slot-steps that went through the fault check
      for (int r = 0; r < cfg.rounds; ++r) {
        Rate raw = timed(w, cfg, step, raw_step);
        Rate bx = timed(w, cfg, step, bidex_step);
        checked += bx.steps * static_cast<int64_t>(n);
        if (raw.per_s() > best_raw.per_s()) best_raw = raw;
        if (bx.per_s() > best_bidex.per_s()) best_bidex = bx;
      }
      for (; checked < cfg.min_checked; checked += n) {
        w.random_inputs(cfg.seed, step++, cfg.max_force, cfg.max_torque);
        bidex_step();
      }
      const int substeps = model.physics().substeps;
      const double raw_slot = best_raw.per_s() * n, bidex_slot = best_bidex.per_s() * n;
      json row = {{"task", task->spec().versioned_id()},
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
                  {"checked_slot_steps", checked},
                  {"faults", w.total_faults() - faults0},
                  {"fault_kinds", w.fault_kinds()},
                  {"overflows", w.total_overflows() - overflows0},
                  {"max_rows", w.max_rows()},
                  {"room_advice", w.room_advice()},
                  {"device_bytes", w.device_bytes()},
                  {"device_bytes_per_world", static_cast<double>(w.device_bytes()) / n}};
      if (cfg.phase_steps > 0) row.update(phases(w, cfg.phase_steps));
      if (cfg.stages && tasks::runs_on_warp(*task)) {
        w.synchronize();
        row.update(task_step(id, n, cfg));
        std::fprintf(stderr, "%s, %d worlds: whole task step %.0f slot-steps/s (ratio %.3f)\n",
                     id.c_str(), n, row["task_slot_steps_per_s"].get<double>(),
                     row["task_ratio_to_raw"].get<double>());
      }
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
          {"results", results},
          {"determinism", determinism_rows}};
}

}  // namespace bidex::bench
