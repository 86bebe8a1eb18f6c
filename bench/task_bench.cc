#include "bench/task_bench.h"

#include <chrono>
#include <cstdio>
#include <random>

#include <mujoco/mujoco.h>

#include "bench/sim_bench.h"
#include "core/progress.h"
#include "tasks/env.h"
#include "tasks/registry.h"

namespace bidex::bench {

using nlohmann::json;

namespace {

mjtNum clock_ms() {
  return std::chrono::duration<double, std::milli>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Steps until min_seconds of timed stepping; actions are drawn outside the timed part.
json measure(tasks::TaskEnv& env, const TaskBenchConfig& cfg, std::mt19937_64& rng) {
  std::vector<float> a(static_cast<size_t>(env.nslot()) * env.act_dim());
  for (int i = 0; i < cfg.warmup_steps; ++i) {
    tasks::random_actions(a, rng);
    env.step(a);
  }
  env.take_stats();
  const int64_t faults0 = env.batch().total_faults();
  double stepping = 0;
  int64_t steps = 0;
  SoakTally tally;  // largest memory use, outside the timed part
  while (stepping < cfg.min_seconds) {
    tasks::random_actions(a, rng);
    auto t0 = std::chrono::steady_clock::now();
    env.step(a);
    stepping += seconds_since(t0);
    ++steps;
    tally.add(env.batch());
  }
  auto st = env.take_stats();
  const double slot_steps = static_cast<double>(steps) * env.nslot();
  const int substeps = env.model().physics().substeps;
  return {{"slots", env.nslot()},
          {"threads", env.threads()},
          {"steps", steps},
          {"seconds", stepping},
          {"slot_steps_per_s", slot_steps / stepping},
          {"physics_steps_per_s", slot_steps * substeps / stepping},
          {"episodes", st.episodes},
          {"faults", env.batch().total_faults() - faults0},
          {"memory", env.model().mj()->narena},
          {"maxuse_arena", tally.maxuse_arena},
          {"maxuse_con", tally.maxuse_con},
          {"maxuse_efc", tally.maxuse_efc}};
}

// A shorter run with the stage timers on: task stages (thread-seconds) and MuJoCo's timers
// summed over every slot's data.
json profile(tasks::TaskEnv& env, const TaskBenchConfig& cfg, std::mt19937_64& rng) {
  std::vector<float> a(static_cast<size_t>(env.nslot()) * env.act_dim());
  auto& batch = env.batch();
  env.reset();
  for (int s = 0; s < env.nslot(); ++s)
    for (int k = 0; k < mjNTIMER; ++k) batch.data(s)->timer[k] = {0, 0};
  mjcb_time = clock_ms;
  env.set_profile(true);
  double stepping = 0;
  while (stepping < cfg.min_seconds / 2) {
    tasks::random_actions(a, rng);
    auto t0 = std::chrono::steady_clock::now();
    env.step(a);
    stepping += seconds_since(t0);
  }
  auto p = env.profile();
  env.set_profile(false);
  mjcb_time = nullptr;
  double timer_s[mjNTIMER] = {};
  for (int s = 0; s < env.nslot(); ++s)
    for (int k = 0; k < mjNTIMER; ++k) timer_s[k] += batch.data(s)->timer[k].duration / 1000.0;
  const double thread_s = p.wall * env.threads();
  json mj;
  for (int k = 0; k < mjNTIMER; ++k)
    if (k != mjTIMER_INVERSE) mj[mjTIMERSTRING[k]] = {{"thread_seconds", timer_s[k]},
                                              {"share_of_step", timer_s[k] / thread_s}};
  // physics = what the threads spent in neither task stage (MuJoCo's step timer agrees to within
  // the cost of applying inputs and copying outputs)
  const double physics = thread_s - p.actions - p.task;
  return {{"steps", p.steps},
          {"wall_seconds", p.wall},
          {"thread_seconds", thread_s},
          {"share", {{"apply_actions", p.actions / thread_s},
                     {"evaluate_reset_observe", p.task / thread_s},
                     {"physics_and_io", physics / thread_s}}},
          {"mujoco_timers", mj},
          {"note", "thread_seconds = wall x threads; MuJoCo timers are summed over slots and "
                   "are nested (step > forward > position > pos_*, collision > broad/narrow)"}};
}

}  // namespace

json run_task_bench(const TaskBenchConfig& cfg) {
  json results = json::array();
  std::mt19937_64 rng(cfg.seed);
  const int64_t total = static_cast<int64_t>(cfg.tasks.size() * cfg.slots.size());
  Progress bar("bench task", total, "measurements");
  int64_t done = 0;
  for (auto& id : cfg.tasks) {
    for (int n : cfg.slots) {
      tasks::EnvOptions eo;
      eo.nslot = n;
      eo.threads = cfg.threads;
      eo.seed = cfg.seed;
      eo.physics_file = cfg.physics_file;
      tasks::TaskEnv env(tasks::make_task(id, cfg.task_config), eo);
      json r = measure(env, cfg, rng);
      r["task"] = env.spec().versioned_id();
      r["task_config"] = env.task().config_file();
      r["substeps"] = env.model().physics().substeps;
      r["timestep"] = env.model().physics().timestep;
      r["bytes_per_slot"] = static_cast<double>(env.batch().bytes()) / n;
      if (cfg.profile) r["profile"] = profile(env, cfg, rng);
      results.push_back(r);
      if (cfg.progress) bar.update(++done);
      std::fprintf(stderr, "%s, %d slots: %.0f slot-steps/s\n", id.c_str(), n,
                   r["slot_steps_per_s"].get<double>());
    }
  }
  if (cfg.progress) bar.finish();
  return {{"benchmark", "task"},
          {"what", "slot-steps/s of whole task steps with random actions: actions, physics "
                   "(substeps), rewards, resets and observations; actions drawn outside the "
                   "timed part"},
          {"results", results}};
}

}  // namespace bidex::bench
