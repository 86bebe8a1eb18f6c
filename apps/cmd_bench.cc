#include <cstdio>
#include <iostream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "bench/sim_bench.h"
#include "core/files.h"
#include "sim/hand_spec.h"

namespace bidex::apps {

namespace {

void emit(const nlohmann::json& j, const std::string& out, const std::string& command) {
  nlohmann::json doc = j;
  doc["machine"] = bench::machine_info();
  doc["command"] = command;
  std::string text = doc.dump(2) + "\n";
  if (out.empty()) {
    std::cout << text;
  } else {
    write_file_atomic(out, text);
    std::fprintf(stderr, "wrote %s\n", out.c_str());
  }
}

}  // namespace

void add_bench_command(CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "Benchmarks; results as JSON (stdout or --out)");
  bench->require_subcommand(1);

  // bench sim
  auto sc = std::make_shared<bench::SimBenchConfig>();
  auto sim_out = std::make_shared<std::string>();
  auto sim_physics = std::make_shared<std::string>();
  auto* sim = bench->add_subcommand(
      "sim", "Physics steps/s and slot-steps/s of the two-hand scene at each thread and slot "
             "count, against a plain OpenMP loop of mj_step on the same worlds; memory per slot");
  sim->add_option("--threads", sc->threads, "Thread counts, e.g. 1,2,4,8,16")->delimiter(',')
      ->capture_default_str();
  sim->add_option("--slots", sc->slots, "Slot counts, e.g. 256,2048")->delimiter(',')
      ->capture_default_str();
  sim->add_option("--seconds", sc->min_seconds, "Least time per measurement")
      ->capture_default_str();
  sim->add_option("--rounds", sc->rounds, "Alternations of baseline and batch (best kept)")
      ->capture_default_str();
  sim->add_option("--memory-slots", sc->memory_slots, "Slots of the memory measurement (0: skip)")
      ->capture_default_str();
  sim->add_option("--physics", *sim_physics, "Physics YAML (default: configs/sim/physics.yaml)");
  sim->add_option("--spec", sc->hand_path, "Hand spec YAML");
  sim->add_option("--out,-o", *sim_out, "Write the JSON here (atomically) instead of stdout");
  sim->footer("Example:\n  bidex bench sim --threads 1,2 --slots 64 --seconds 0.5 --memory-slots 0");
  sim->callback([sc, sim_out, sim_physics] {
    sc->physics = sim::load_physics(sim_physics->empty() ? sim::default_physics_path()
                                                         : *sim_physics);
    emit(bench::run_sim_bench(*sc), *sim_out, command_line());
  });

  // bench soak
  auto so = std::make_shared<bench::SoakConfig>();
  auto soak_out = std::make_shared<std::string>();
  auto soak_physics = std::make_shared<std::string>();
  auto* soak = bench->add_subcommand(
      "soak", "Random-action slot-steps of the two-hand scene; counts faults by kind and the "
              "largest MuJoCo memory use (the physics settings must give zero faults)");
  soak->add_option("--slots", so->slots, "Parallel worlds")->capture_default_str();
  soak->add_option("--slot-steps", so->slot_steps, "Control steps summed over slots")
      ->capture_default_str();
  soak->add_option("--threads", so->threads, "Threads (0: all cores)")->capture_default_str();
  soak->add_option("--seed", so->seed, "Run seed")->capture_default_str();
  soak->add_option("--force", so->max_force, "Largest random base force (N)")
      ->capture_default_str();
  soak->add_option("--torque", so->max_torque, "Largest random base torque (N m)")
      ->capture_default_str();
  soak->add_option("--physics", *soak_physics, "Physics YAML (default: configs/sim/physics.yaml)");
  soak->add_option("--spec", so->hand_path, "Hand spec YAML");
  soak->add_option("--out,-o", *soak_out, "Write the JSON here (atomically) instead of stdout");
  soak->footer("Example:\n  bidex bench soak --slots 512 --slot-steps 1000000 -o soak.json");
  soak->callback([so, soak_out, soak_physics] {
    so->physics = sim::load_physics(soak_physics->empty() ? sim::default_physics_path()
                                                          : *soak_physics);
    emit(bench::run_soak(*so), *soak_out, command_line());
  });
}

}  // namespace bidex::apps
