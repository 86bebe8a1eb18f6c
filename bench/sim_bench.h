// Throughput of the batched simulation against a plain OpenMP loop of mj_step over the same
// worlds, measured in one run; and a soak run counting faults under random actions.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "sim/batch.h"
#include "sim/physics.h"

namespace bidex::sim {
class SimModel;
class SimBatch;
}  // namespace bidex::sim

namespace bidex::bench {

struct SimBenchConfig {
  std::vector<int> threads{1};        // thread counts to measure
  std::vector<int> slots{256};        // slot counts to measure
  double min_seconds = 1.0;           // per measurement (at least one control step)
  int rounds = 3;                     // alternations of baseline and batch; the best of each is kept
  double max_force = 83.3;            // random base force (N), catch_underarm's limit
  double max_torque = 8.33;           // random base torque (N m)
  int memory_slots = 8192;            // slots of the memory measurement (0: skip)
  sim::PhysicsOptions physics;
  std::string hand_path;
  bool progress = true;
};

// Runs every (slots, threads) pair and returns the results as JSON.
nlohmann::json run_sim_bench(const SimBenchConfig& cfg);

// Seconds elapsed since `t0`.
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// What a soak watches over many steps: faults by kind (sim::FaultBits) and the largest MuJoCo
// memory use of any slot (arena bytes, contacts, constraint rows).
struct SoakTally {
  int64_t by_kind[sim::kFaultKinds] = {};
  int64_t maxuse_arena = 0;
  int maxuse_con = 0, maxuse_efc = 0;
  void add(const sim::SimBatch& batch);     // after each step
  void to_json(nlohmann::json& out) const;  // faults_bad_input, ..., maxuse_arena, ...
};

// Resets the slots whose episode of `episode_steps` control steps ends after control step
// `step_index` (0-based); episodes are staggered over slots so resets spread over time.
void reset_finished_episodes(const sim::SimModel& model, sim::SimBatch& batch, int64_t step_index,
                             int episode_steps);

struct SoakConfig {
  int slots = 256;
  int64_t slot_steps = 1000000;  // control steps summed over slots
  int threads = 0;
  uint64_t seed = 1;
  double max_force = 83.3;
  double max_torque = 8.33;
  int episode_steps = 75;        // reset each slot after this many control steps (0: never)
  sim::PhysicsOptions physics;
  std::string hand_path;
  bool progress = true;
};

// Steps the two-hand scene under random actions; returns counts of faults by kind, rates and
// the largest MuJoCo memory use seen (stack, contacts, constraint rows).
nlohmann::json run_soak(const SoakConfig& cfg);

// Machine facts for a results file: host name, CPU model, cores, date (UTC), git commit.
nlohmann::json machine_info();

}  // namespace bidex::bench
