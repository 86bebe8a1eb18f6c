#include <cmath>
#include <cstdio>

#include <CLI/CLI.hpp>

#include "apps/commands.h"
#include "core/files.h"
#include <mujoco/mujoco.h>

#include "sim/scene.h"
#include "tasks/env.h"
#include "tasks/registry.h"

namespace bidex::apps {

void add_model_command(CLI::App& app) {
  struct Opts {
    std::string hand = "both", out, spec, base = "fixed", physics, task, task_config;
    bool gpu = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "model",
      "Write standalone MJCF of the generated Shadow Hand(s), or of a task's whole scene; MuJoCo's "
      "own tools open it");
  auto* hand = cmd->add_option("--hand", o->hand, "Which hand: right, left or both")
                   ->check(CLI::IsMember({"right", "left", "both"}))
                   ->capture_default_str();
  cmd->add_option("--out,-o", o->out, "Output file (MJCF XML)")->required();
  cmd->add_option("--spec", o->spec, "Hand spec YAML (default: configs/hands/shadow.yaml)");
  auto* base = cmd->add_option("--base", o->base, "Base of each hand: fixed, or free (6-DoF, damped)")
                   ->check(CLI::IsMember({"fixed", "free"}))
                   ->capture_default_str();
  cmd->add_option("--physics", o->physics, "Physics YAML (default: configs/sim/physics.yaml)");
  auto* task = cmd->add_option("--task", o->task,
                               "A task's scene instead (hands placed for it, objects, goal "
                               "markers, tables), as its simulation compiles it")
                   ->excludes(hand)
                   ->excludes(base);
  cmd->add_option("--task-config", o->task_config,
                  "The task's YAML (default: tasks/ID/ID.yaml)")
      ->needs(task);
  cmd->add_flag("--gpu", o->gpu,
                "With --task: the scene as the GPU path (MuJoCo Warp) steps it, with the physics "
                "YAML's GPU settings")
      ->needs(task);
  cmd->footer(
      "Examples:\n  bidex model --hand both --out hands.xml\n  .venv/bin/python -c \"import mujoco; "
      "print(mujoco.MjModel.from_xml_path('hands.xml').nq)\"\n"
      "  bidex model --task door_open_inward --out door.xml\n"
      "  .venv/bin/python -m mujoco.viewer --mjcf=door.xml");
  cmd->callback([o] {
    if (!o->task.empty()) {
      // the task's own scene, built and compiled as its environment builds it
      std::unique_ptr<tasks::Task> t = tasks::make_task(o->task, o->task_config);
      std::unique_ptr<sim::SimModel> model =
          tasks::build_task_model(*t, o->spec, o->physics, o->gpu);
      write_file_atomic(o->out, model->mjcf());
      std::printf("wrote %s: the scene of %s (%s), %d bodies, %d joints, %d actuators, %d geoms\n",
                  o->out.c_str(), t->spec().versioned_id().c_str(), t->config_file().c_str(),
                  model->nbody(), static_cast<int>(model->mj()->njnt), model->nu(),
                  static_cast<int>(model->mj()->ngeom));
      return;
    }
    auto spec = sim::load_hand_spec(o->spec.empty() ? sim::default_hand_path() : o->spec);
    auto physics = sim::load_physics(o->physics.empty() ? sim::default_physics_path() : o->physics);
    sim::SceneBuilder sb(physics);
    sim::Base base = o->base == "free" ? sim::Base::kFree : sim::Base::kFixed;
    // hands face each other across the y axis, as in hand_over
    if (o->hand != "left")
      sb.add_hand(spec, {sim::Side::kRight, sim::Pose::rpy({0, 0, 0.5}, 0, 0, 0), base});
    if (o->hand != "right")
      sb.add_hand(spec, {sim::Side::kLeft, sim::Pose::rpy({0, -1, 0.5}, 0, 0, M_PI), base});
    // compile before writing: a file on disk is always a model MuJoCo accepts
    sim::SimModel model = sb.build(o->out);
    write_file_atomic(o->out, model.mjcf());
    std::printf("wrote %s: %d bodies, %d joints, %d actuators, %d sensors\n", o->out.c_str(),
                model.nbody(), static_cast<int>(model.mj()->njnt), model.nu(),
                static_cast<int>(model.mj()->nsensor));
  });
}

}  // namespace bidex::apps
