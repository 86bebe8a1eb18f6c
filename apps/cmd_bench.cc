#include <cstdio>
#include <iostream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "bench/agree_bench.h"
#include "bench/pack_bench.h"
#include "bench/pair_audit.h"
#include "bench/physics_study.h"
#include "bench/sim_bench.h"
#include "bench/task_bench.h"
#include "bench/warp_bench.h"
#include "core/error.h"
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
  soak->add_option("--episode-steps", so->episode_steps,
                   "Reset each slot after this many control steps, staggered (0: never)")
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

  // bench task
  auto tc = std::make_shared<bench::TaskBenchConfig>();
  auto task_out = std::make_shared<std::string>();
  auto* task = bench->add_subcommand(
      "task", "Slot-steps/s of whole task steps (random actions, physics, rewards, resets, "
              "observations) for each task and slot count, with a profile of where the time goes");
  task->add_option("--task", tc->tasks, "Task ids, e.g. catch_underarm,hand_over")
      ->delimiter(',')->required();
  task->add_option("--slots", tc->slots, "Slot counts")->delimiter(',')->capture_default_str();
  task->add_option("--threads", tc->threads, "Threads (0: all cores)")->capture_default_str();
  task->add_option("--seconds", tc->min_seconds, "Timed stepping per measurement")
      ->capture_default_str();
  task->add_option("--seed", tc->seed, "Seed")->capture_default_str();
  task->add_option("--physics", tc->physics_file, "Physics YAML (default: configs/sim/physics.yaml)");
  task->add_flag("!--no-profile", tc->profile, "Skip the profiled run");
  task->add_option("--config", tc->task_config, "Task YAML (one --task only; default: its own)");
  task->add_option("--out,-o", *task_out, "Write the JSON here (atomically) instead of stdout");
  task->footer("Example:\n  bidex bench task --task catch_underarm --slots 64 --seconds 1");
  task->callback([tc, task_out] {
    if (!tc->task_config.empty() && tc->tasks.size() != 1)
      throw Error("bench task: --config takes one --task, got " +
                  std::to_string(tc->tasks.size()));
    emit(bench::run_task_bench(*tc), *task_out, command_line());
  });

  // bench pairs
  auto pa = std::make_shared<bench::PairAuditConfig>();
  auto pairs_out = std::make_shared<std::string>();
  auto* pairs = bench->add_subcommand(
      "pairs", "The collision-pair audit: per task scene, the geom pairs each world tests (as "
               "MuJoCo Warp's broadphase lists them), by what they join (hand and itself, the two "
               "hands, hand and object, hand and world, ...) and by the GPU's narrowphase path "
               "(primitive or convex GJK/EPA); a table on stderr");
  pairs->add_option("--task", pa->tasks, "Task ids (default: all 22)")->delimiter(',');
  pairs->add_option("--physics", pa->physics_file,
                    "Physics YAML (default: configs/sim/physics.yaml)");
  pairs->add_flag("!--cpu", pa->on_gpu, "The scenes as the CPU builds them (default: the GPU's)");
  pairs->add_option("--out,-o", *pairs_out, "Write the JSON here (atomically) instead of stdout");
  pairs->footer("Example:\n  bidex bench pairs --task catch_underarm,bottle_cap -o pairs.json");
  pairs->callback([pa, pairs_out] {
    nlohmann::json j = bench::run_pair_audit(*pa);
    std::fprintf(stderr, "%-22s %6s %6s %5s %5s %5s %5s %5s %5s %6s\n", "task", "geoms", "pairs",
                 "self", "hands", "h-obj", "h-wld", "o-obj", "o-wld", "convex");
    for (auto& t : j["tasks"]) {
      auto& k = t["by_kind"];
      std::fprintf(stderr, "%-22s %6d %6d %5d %5d %5d %5d %5d %5d %6d\n",
                   t["task"].get<std::string>().c_str(), t["geoms"].get<int>(),
                   t["pairs_listed"].get<int>(), k["hand_self"].get<int>(),
                   k["hand_hand"].get<int>(), k["hand_object"].get<int>(),
                   k["hand_world"].get<int>(), k["object_object"].get<int>(),
                   k["object_world"].get<int>(), t["convex"].get<int>());
    }
    emit(j, *pairs_out, command_line());
  });

  // bench pack
  auto pc = std::make_shared<bench::PackBenchConfig>();
  auto pack_out = std::make_shared<std::string>();
  auto* pack = bench->add_subcommand(
      "pack", "Slot-steps/s of a suite's tasks packed in one instance against each task alone at "
              "the same slot count (random actions, alternating rounds, the best of each kept)");
  pack->add_option("--suite", pc->suite, "Suite id or file (its train split)")->capture_default_str();
  pack->add_option("--slots", pc->slots, "Slots of the pack in all, and of each task alone")
      ->check(CLI::PositiveNumber)->capture_default_str();
  pack->add_option("--threads", pc->threads, "Threads (0: all cores)")->capture_default_str();
  pack->add_option("--seconds", pc->min_seconds, "Timed stepping per measurement")
      ->capture_default_str();
  pack->add_option("--rounds", pc->rounds, "Alternations of packed and single measurements")
      ->check(CLI::PositiveNumber)->capture_default_str();
  pack->add_option("--seed", pc->seed, "Seed")->capture_default_str();
  pack->add_option("--device", pc->device,
                   "cpu (MuJoCo, all cores) or cuda (MuJoCo Warp: scenes of one topology share "
                   "a backend, each backend on its own stream; the pack is also measured with "
                   "one backend per scene)")
      ->check(CLI::IsMember({"cpu", "cuda"}))->capture_default_str();
  pack->add_option("--out,-o", *pack_out, "Write the JSON here (atomically) instead of stdout");
  pack->footer("Example:\n  bidex bench pack --suite MT4 --slots 64 --seconds 0.5 --rounds 1");
  pack->callback([pc, pack_out] {
    request_gpu_queues(pc->device);
    emit(bench::run_pack_bench(*pc), *pack_out, command_line());
  });

  // bench warp
  auto wc = std::make_shared<bench::WarpBenchConfig>();
  auto warp_out = std::make_shared<std::string>();
  auto* warp = bench->add_subcommand(
      "warp", "The GPU backend on MuJoCo Warp: bidex's control step (base forces, fault check, "
              "reset and position passes) against raw MuJoCo Warp on each task's scene and world "
              "count, in one run, random inputs; needs an NVIDIA GPU and MuJoCo Warp (README, "
              "'With a GPU')");
  warp->add_option("--task", wc->tasks, "Task ids (their scenes), e.g. catch_underarm,hand_over")
      ->delimiter(',')->required();
  warp->add_option("--worlds", wc->worlds, "World counts")->delimiter(',')
      ->check(CLI::PositiveNumber)->capture_default_str();
  warp->add_option("--device", wc->device, "Warp device: cuda, cuda:N, or cpu (plumbing only)")
      ->capture_default_str();
  warp->add_option("--seconds", wc->min_seconds, "Timed stepping per measurement")
      ->capture_default_str();
  warp->add_option("--rounds", wc->rounds, "Alternations of raw and bidex (best of each kept)")
      ->check(CLI::PositiveNumber)->capture_default_str();
  warp->add_option("--njmax", wc->njmax, "Constraint rows per world (0: the scene's gpu.njmax)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  warp->add_option("--nconmax", wc->nconmax, "Contacts per world (0: the scene's gpu.nconmax)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  warp->add_option("--physics", wc->physics_file,
                   "Physics YAML (default: configs/sim/physics.yaml)");
  warp->add_option("--seed", wc->seed, "Seed of the random inputs")->capture_default_str();
  warp->add_flag("!--no-stages", wc->stages,
                 "Skip the whole task step (the task stages on the GPU)");
  warp->add_option("--determinism-steps", wc->determinism_steps,
                   "Steps of two fresh backends compared for bitwise equality, per task (0: skip)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  warp->add_option("--min-checked", wc->min_checked,
                   "Fault-checked slot-steps per task at least, however fast the GPU steps: "
                   "untimed steps after the timed rounds make up the rest")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  warp->add_option("--phases", wc->phase_steps,
                   "Control steps to reach a state on which raw stepping's parts are each timed: "
                   "the shares of a substep in collision, constraint rows and the solver (0: skip)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  warp->add_option("--out,-o", *warp_out, "Write the JSON here (atomically) instead of stdout");
  warp->footer("Example:\n  bidex bench warp --task catch_underarm --worlds 2048,8192 --seconds 2");
  warp->callback([wc, warp_out] { emit(bench::run_warp_bench(*wc), *warp_out, command_line()); });

  // bench agree
  auto ac = std::make_shared<bench::AgreeBenchConfig>();
  auto agree_out = std::make_shared<std::string>();
  auto* agree = bench->add_subcommand(
      "agree", "CPU path against GPU path: a random policy's episodes on each task, mean return, "
               "length and success rate of each with standard errors, and whether they agree "
               "within 4 standard errors + 2% (+0.01 for success)");
  agree->add_option("--task", ac->tasks, "Task ids")->delimiter(',')->required();
  agree->add_option("--episodes", ac->episodes, "Finished episodes per side, at least")
      ->check(CLI::PositiveNumber)->capture_default_str();
  agree->add_option("--slots", ac->slots, "Slots (CPU) and worlds (GPU)")
      ->check(CLI::PositiveNumber)->capture_default_str();
  agree->add_option("--threads", ac->threads, "CPU threads (0: all cores)")->capture_default_str();
  agree->add_option("--device", ac->device, "Warp device: cuda, cuda:N, or cpu")
      ->capture_default_str();
  agree->add_option("--seed", ac->seed, "Seed")->capture_default_str();
  agree->add_option("--out,-o", *agree_out, "Write the JSON here (atomically) instead of stdout");
  agree->footer("Example:\n  bidex bench agree --task catch_underarm,hand_over --episodes 1000");
  agree->callback(
      [ac, agree_out] { emit(bench::run_agree_bench(*ac), *agree_out, command_line()); });

  // bench physics
  auto ps = std::make_shared<bench::PhysicsStudyConfig>();
  auto ps_out = std::make_shared<std::string>();
  auto ps_physics = std::make_shared<std::string>();
  auto* phys = bench->add_subcommand(
      "physics",
      "The physics study: sweeps timestep/substeps, the integrator (Euler, implicitfast, "
      "discrete) at 8, 4 and 2 substeps, solver, contact and coupling softness, finger "
      "damping and gain, joint friction and base damping one at a time around the current "
      "configuration; for "
      "each: cost (1 thread), faults under random actions (catch_underarm's and the hardest "
      "task's base limits), the egg at rest on the palm, coupling error during a finger sweep, "
      "a grasped egg held 10 s against gravity, the free base's hang and push, a finger step "
      "response; then memory per slot");
  phys->add_option("--groups", ps->groups,
                   "Sweeps to run: timestep, integrator, solver, contact, coupling, damping, "
                   "frictionloss, kp, base; 'reference' alone runs the reference only (default: "
                   "all)")
      ->delimiter(',')
      ->check(CLI::IsMember({"reference", "timestep", "integrator", "solver", "contact",
                             "coupling", "damping", "frictionloss", "kp", "base"}));
  phys->add_option("--soak-slot-steps", ps->soak.slot_steps,
                   "Random-action slot-steps per candidate at catch_underarm's limits")
      ->capture_default_str();
  phys->add_option("--hard-slot-steps", ps->hard.slot_steps,
                   "Slot-steps per candidate at the hardest limits (0: skip)")
      ->capture_default_str();
  phys->add_option("--slots", ps->soak.slots, "Slots of each soak (one thread)")
      ->check(CLI::PositiveNumber)->capture_default_str();
  phys->add_option("--episode-steps", ps->soak.episode_steps,
                   "Reset each soak slot this often (staggered; 0: never)")
      ->capture_default_str();
  phys->add_option("--force", ps->soak.max_force, "Random base force (N) of the soak")
      ->capture_default_str();
  phys->add_option("--torque", ps->soak.max_torque, "Random base torque (N m) of the soak")
      ->capture_default_str();
  phys->add_option("--hard-force", ps->hard.max_force, "Random base force (N) of the hard soak")
      ->capture_default_str();
  phys->add_option("--hard-torque", ps->hard.max_torque,
                   "Random base torque (N m) of the hard soak")
      ->capture_default_str();
  phys->add_option("--seed", ps->soak.seed, "Seed of the soaks (the hard soak uses seed + 1)")
      ->capture_default_str();
  phys->add_option("--cost-steps", ps->cost.steps,
                   "Control steps of each cost round (16 slots, one thread)")
      ->check(CLI::PositiveNumber)->capture_default_str();
  phys->add_option("--cost-rounds", ps->cost.rounds,
                   "Identical cost rounds per candidate, the fastest kept (0: skip)")
      ->capture_default_str();
  phys->add_option("--memory-slots", ps->memory_slots, "Slot count of the memory figures")
      ->capture_default_str();
  phys->add_option("--physics", *ps_physics,
                   "Reference physics YAML (default: configs/sim/physics.yaml)");
  phys->add_option("--spec", ps->hand_path, "Reference hand spec YAML");
  phys->add_option("--out,-o", *ps_out, "Write the JSON here (atomically) instead of stdout");
  phys->footer(
      "About 5 minutes on 2 cores at the defaults (each soak runs on one thread).\n"
      "Examples:\n"
      "  bidex bench physics -o bench/results/physics_study-MACHINE.json\n"
      "  bidex bench physics --groups solver,contact --soak-slot-steps 2000 --hard-slot-steps 0");
  phys->callback([ps, ps_out, ps_physics] {
    ps->physics = sim::load_physics(ps_physics->empty() ? sim::default_physics_path()
                                                        : *ps_physics);
    ps->hard.slots = ps->soak.slots;
    ps->hard.episode_steps = ps->soak.episode_steps;
    ps->hard.seed = ps->soak.seed + 1;
    ps->cost.max_force = ps->soak.max_force;
    ps->cost.max_torque = ps->soak.max_torque;
    emit(bench::run_physics_study(*ps), *ps_out, command_line());
  });
}

}  // namespace bidex::apps
