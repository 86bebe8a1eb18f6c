#include "bench/sim_bench.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <memory>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>
#include <omp.h>
#include <unistd.h>

#include "core/progress.h"
#include "sim/batch.h"
#include "sim/scene.h"

namespace bidex::bench {

using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {


std::string run_command(const std::string& cmd) {
  std::string out;
  if (FILE* p = ::popen(cmd.c_str(), "r")) {
    char buf[256];
    while (std::fgets(buf, sizeof buf, p)) out += buf;
    ::pclose(p);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out;
}

size_t resident_bytes() {
  std::ifstream in("/proc/self/statm");
  size_t pages_total = 0, pages_resident = 0;
  in >> pages_total >> pages_resident;
  return pages_resident * static_cast<size_t>(::sysconf(_SC_PAGESIZE));
}

sim::SimModel build_scene(const std::string& hand_path, const sim::PhysicsOptions& physics) {
  auto hand = sim::load_hand_spec(hand_path.empty() ? sim::default_hand_path() : hand_path);
  return sim::two_hand_scene(hand, physics).build("two_hand_scene");
}

// the reference: a plain OpenMP loop of mj_step over S worlds with the same inputs
struct Baseline {
  const sim::SimModel& model;
  std::vector<mjData*> data;

  Baseline(const sim::SimModel& m, sim::SimBatch& batch) : model(m) {
    for (int s = 0; s < batch.nslot(); ++s) {
      mjData* d = mj_makeData(m.mj());
      mj_copyData(d, m.mj(), batch.data(s));
      data.push_back(d);
    }
  }
  ~Baseline() {
    for (auto* d : data) mj_deleteData(d);
  }

  void step(const sim::SimBatch& b, int threads) {
    const mjModel* m = model.mj();
    const int substeps = model.physics().substeps, nu = m->nu, nw = b.base_wrench_width;
    const int n = static_cast<int>(data.size());
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int s = 0; s < n; ++s) {
      mjData* d = data[s];
      const double* ctrl = b.ctrl.data() + static_cast<size_t>(s) * nu;
      const double* wrench = b.base_wrench.data() + static_cast<size_t>(s) * nw;
      sim::apply_inputs(model, d, ctrl, wrench);
      for (int k = 0; k < substeps; ++k) {
        if (k > 0) sim::update_base_wrench(model, d, wrench);
        mj_step(m, d);
      }
    }
  }
};

}  // namespace

void SoakTally::add(const sim::SimBatch& batch) {
  for (int s = 0; s < batch.nslot(); ++s) {
    for (int k = 0; k < sim::kFaultKinds; ++k)
      if (batch.fault[s] & (1u << k)) ++by_kind[k];
    const mjData* d = batch.data(s);
    maxuse_arena = std::max(maxuse_arena, static_cast<int64_t>(d->maxuse_arena));
    maxuse_con = std::max(maxuse_con, d->maxuse_con);
    maxuse_efc = std::max(maxuse_efc, d->maxuse_efc);
  }
}

void SoakTally::to_json(json& out) const {
  for (int k = 0; k < sim::kFaultKinds; ++k)
    out[std::string("faults_") + sim::fault_kind_name(k)] = by_kind[k];
  out["maxuse_arena"] = maxuse_arena;
  out["maxuse_con"] = maxuse_con;
  out["maxuse_efc"] = maxuse_efc;
}

void reset_finished_episodes(const sim::SimModel& model, sim::SimBatch& batch, int64_t step_index,
                             int episode_steps) {
  if (episode_steps <= 0) return;
  for (int s = 0; s < batch.nslot(); ++s) {
    int64_t offset = static_cast<int64_t>(s) * episode_steps / batch.nslot();
    if ((step_index + 1 + offset) % episode_steps == 0) sim::reset_slot(model, batch, s);
  }
}

json machine_info() {
  json j;
  char host[256] = "";
  ::gethostname(host, sizeof host);
  j["host"] = host;
  std::string cpu = run_command("grep -m1 'model name' /proc/cpuinfo | cut -d: -f2");
  j["cpu"] = cpu.empty() ? "unknown" : cpu.substr(cpu.find_first_not_of(' '));
  j["cores"] = omp_get_num_procs();
  j["gpu"] = run_command("nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1");
  std::time_t now = std::time(nullptr);
  char date[64];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  j["date"] = date;
  std::string commit = run_command(std::string("git -C '") + BIDEX_SOURCE_DIR +
                                   "' rev-parse --short HEAD 2>/dev/null");
  std::string dirty = run_command(std::string("git -C '") + BIDEX_SOURCE_DIR +
                                  "' status --porcelain --untracked-files=no 2>/dev/null");
  j["commit"] = commit.empty() ? "unknown" : commit + (dirty.empty() ? "" : "-dirty");
  // a tree built outside its git checkout (an exported snapshot) is told its commit
  if (const char* c = std::getenv("BIDEX_COMMIT"); c && *c) j["commit"] = c;
  j["mujoco"] = mj_version();
  return j;
}

json run_sim_bench(const SimBenchConfig& cfg) {
  sim::SimModel model = build_scene(cfg.hand_path, cfg.physics);
  const int substeps = model.physics().substeps;
  json out;
  out["scene"] = {{"name", "two_hand_scene"}, {"nq", model.nq()}, {"nv", model.nv()},
                  {"nu", model.nu()}, {"nbody", model.nbody()},
                  {"timestep", model.physics().timestep}, {"substeps", substeps},
                  {"solver", model.physics().solver}, {"iterations", model.physics().iterations}};
  out["runs"] = json::array();

  int64_t total = static_cast<int64_t>(cfg.slots.size() * cfg.threads.size());
  Progress bar("bench sim", total, "runs");
  int64_t done = 0;
  for (int nslot : cfg.slots) {
    for (int threads : cfg.threads) {
      sim::SimBatch batch(model, nslot, {threads, /*seed=*/7});
      Baseline base(model, batch);
      double best_base = 1e300, best_batch = 1e300;
      int64_t faults = 0;
      for (int round = 0; round < cfg.rounds; ++round) {
        // plain loop
        double t = 0;
        int steps = 0;
        while (steps == 0 || t < cfg.min_seconds) {
          sim::random_inputs(model, batch, cfg.max_force, cfg.max_torque);
          auto t0 = Clock::now();
          base.step(batch, threads);
          t += seconds_since(t0);
          ++steps;
        }
        best_base = std::min(best_base, t / steps);
        // the batch layer on the same inputs
        t = 0;
        steps = 0;
        while (steps == 0 || t < cfg.min_seconds) {
          sim::random_inputs(model, batch, cfg.max_force, cfg.max_torque);
          auto t0 = Clock::now();
          sim::step(model, batch);
          t += seconds_since(t0);
          ++steps;
        }
        best_batch = std::min(best_batch, t / steps);
      }
      faults = batch.total_faults();
      double base_sps = nslot / best_base, batch_sps = nslot / best_batch;
      out["runs"].push_back({{"slots", nslot},
                             {"threads", threads},
                             {"baseline_physics_steps_per_s", base_sps * substeps},
                             {"batch_physics_steps_per_s", batch_sps * substeps},
                             {"baseline_slot_steps_per_s", base_sps},
                             {"batch_slot_steps_per_s", batch_sps},
                             {"batch_overhead", best_batch / best_base - 1.0},
                             {"faults", faults}});
      bar.update(++done);
    }
  }
  bar.finish();

  // scaling relative to one thread at the same slot count
  for (auto& r : out["runs"]) {
    for (auto& one : out["runs"])
      if (one["slots"] == r["slots"] && one["threads"] == 1)
        r["batch_speedup_vs_1_thread"] =
            r["batch_slot_steps_per_s"].get<double>() / one["batch_slot_steps_per_s"].get<double>();
  }

  // memory: allocated by MuJoCo per slot, and resident growth of a large batch
  json mem;
  mem["mjdata_bytes_per_slot"] = model.data_bytes();
  if (cfg.memory_slots > 0) {
    size_t before = resident_bytes();
    auto big = std::make_unique<sim::SimBatch>(model, cfg.memory_slots, sim::BatchOptions{});
    size_t after = resident_bytes();
    mem["slots"] = cfg.memory_slots;
    mem["batch_bytes"] = big->bytes();
    mem["batch_bytes_per_slot"] = big->bytes() / cfg.memory_slots;
    mem["resident_growth_bytes"] = after - before;
    mem["resident_bytes_per_slot"] = (after - before) / cfg.memory_slots;
    mem["fits_8GB"] = big->bytes() <= 8ull * 1000 * 1000 * 1000;
  }
  out["memory"] = mem;
  return out;
}

json run_soak(const SoakConfig& cfg) {
  sim::SimModel model = build_scene(cfg.hand_path, cfg.physics);
  sim::SimBatch batch(model, cfg.slots, {cfg.threads, cfg.seed});
  const int64_t steps = (cfg.slot_steps + cfg.slots - 1) / cfg.slots;
  SoakTally tally;
  Progress bar("soak", steps * cfg.slots, "slot-steps");
  auto t0 = Clock::now();
  for (int64_t i = 0; i < steps; ++i) {
    sim::random_inputs(model, batch, cfg.max_force, cfg.max_torque);
    sim::step(model, batch);
    tally.add(batch);
    reset_finished_episodes(model, batch, i, cfg.episode_steps);
    if (cfg.progress) bar.update((i + 1) * cfg.slots);
  }
  double secs = seconds_since(t0);
  if (cfg.progress) bar.finish();
  const auto& p = model.physics();
  json out{{"slots", cfg.slots},
              {"slot_steps", steps * cfg.slots},
              {"threads", batch.threads()},
              {"seconds", secs},
              {"slot_steps_per_s", steps * cfg.slots / secs},
              {"faults", batch.total_faults()},
              {"episode_steps", cfg.episode_steps},
              {"memory", model.mj()->narena},
              {"timestep", p.timestep},
              {"substeps", p.substeps},
              {"max_force", cfg.max_force},
              {"max_torque", cfg.max_torque}};
  tally.to_json(out);
  return out;
}

}  // namespace bidex::bench
