#include <chrono>
#include <cstdio>

#include <CLI/CLI.hpp>
#include <torch/torch.h>

#include "apps/commands.h"
#include "core/progress.h"
#include "sim/batch.h"
#include "sim/scene.h"
#include "sim/tensor.h"

namespace bidex::apps {

void add_sim_command(CLI::App& app) {
  struct Opts {
    int slots = 64, steps = 240, threads = 0;
    uint64_t seed = 1;
    std::string spec, physics;
    double force = 83.3, torque = 8.33;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "sim", "Step the two-hand scene (free bases, an egg) under random actions; report speed and "
             "faults, and hand the state to LibTorch on the GPU if there is one");
  cmd->add_option("--slots", o->slots, "Parallel worlds")->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--steps", o->steps, "Control steps (60 Hz) per slot")
      ->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads (0: all cores)")->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the per-slot random streams")->capture_default_str();
  cmd->add_option("--force", o->force, "Largest random base force (N)")->capture_default_str();
  cmd->add_option("--torque", o->torque, "Largest random base torque (N m)")->capture_default_str();
  cmd->add_option("--spec", o->spec, "Hand spec YAML (default: configs/hands/shadow.yaml)");
  cmd->add_option("--physics", o->physics, "Physics YAML (default: configs/sim/physics.yaml)");
  cmd->footer("Example:\n  bidex sim --slots 256 --steps 600 --threads 2");
  cmd->callback([o] {
    auto spec = sim::load_hand_spec(o->spec.empty() ? sim::default_hand_path() : o->spec);
    auto physics = sim::load_physics(o->physics.empty() ? sim::default_physics_path() : o->physics);
    sim::SimModel model = sim::two_hand_scene(spec, physics).build("two_hand_scene");
    sim::SimBatch batch(model, o->slots, {o->threads, o->seed});
    c10::Device device = sim::default_device();
    std::printf("two-hand scene: %d slots, %d threads, dt %.4g s x %d substeps, %.1f MB, "
                "tensors on %s\n",
                batch.nslot(), batch.threads(), physics.timestep, physics.substeps,
                batch.bytes() / 1e6, device.str().c_str());

    Progress bar("sim", static_cast<int64_t>(o->steps) * o->slots, "slot-steps");
    double sim_seconds = 0, copy_seconds = 0, height_sum = 0;
    const auto* egg = model.object("object");
    for (int i = 0; i < o->steps; ++i) {
      sim::random_inputs(model, batch, o->force, o->torque);
      auto t0 = std::chrono::steady_clock::now();
      sim::step(model, batch);
      auto t1 = std::chrono::steady_clock::now();
      // the learning side sees a tensor of the state, on its device
      at::Tensor qpos = sim::to_tensor(batch.qpos, batch.nslot(), batch.qpos_width, device);
      height_sum += qpos.select(1, egg->qpos_adr + 2).mean().item<double>();
      auto t2 = std::chrono::steady_clock::now();
      sim_seconds += std::chrono::duration<double>(t1 - t0).count();
      copy_seconds += std::chrono::duration<double>(t2 - t1).count();
      bar.update(static_cast<int64_t>(i + 1) * o->slots);
    }
    bar.finish();
    double slot_steps = static_cast<double>(o->steps) * o->slots;
    std::printf("%.0f slot-steps/s (%.0f physics steps/s), tensor hand-off %.1f%% of the time\n",
                slot_steps / sim_seconds, slot_steps * physics.substeps / sim_seconds,
                100 * copy_seconds / (sim_seconds + copy_seconds));
    std::printf("faults: %lld in %.0f slot-steps; mean egg height %.3f m\n",
                static_cast<long long>(batch.total_faults()), slot_steps, height_sum / o->steps);
  });
}

}  // namespace bidex::apps
