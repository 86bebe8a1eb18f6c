// bidex render: a picture of a task's initial scene, drawn headless by MuJoCo's renderer.
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "apps/commands.h"
#include "sim/render.h"
#include "tasks/env.h"
#include "tasks/registry.h"

namespace bidex::apps {

void add_render_command(CLI::App& app) {
  struct Opts {
    std::string task, out, config;
    int width = 800, height = 600;
    uint64_t seed = 1;
    double azimuth = NAN, elevation = NAN, distance = NAN;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "render", "Render a task's initial scene (after one reset) to a PNG, headless "
                "(MuJoCo's renderer in an offscreen OpenGL context; backend: " +
                    std::string(sim::render_backend()) + ")");
  cmd->add_option("--task", o->task, "Task id")->required();
  cmd->add_option("--out,-o", o->out, "PNG file to write (atomically)")->required();
  cmd->add_option("--config", o->config, "Task YAML (default: the task's own)");
  cmd->add_option("--width", o->width, "Pixels")->check(CLI::Range(16, 4096))
      ->capture_default_str();
  cmd->add_option("--height", o->height, "Pixels")->check(CLI::Range(16, 4096))
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the reset (object and goal orientations)")
      ->capture_default_str();
  cmd->add_option("--azimuth", o->azimuth, "Camera azimuth, degrees (default: framing view)");
  cmd->add_option("--elevation", o->elevation, "Camera elevation, degrees (negative: from above)");
  cmd->add_option("--distance", o->distance, "Camera distance, metres");
  cmd->footer("Example:\n  bidex render --task catch_underarm --out catch_underarm.png");
  cmd->callback([o] {
    tasks::EnvOptions eo;
    eo.nslot = 1;
    eo.threads = 1;
    eo.seed = o->seed;
    tasks::TaskEnv env(tasks::make_task(o->task, o->config), eo);
    const mjData* d = env.batch().data(0);
    sim::RenderOptions ro;
    ro.width = o->width;
    ro.height = o->height;
    ro.camera = sim::framing_camera(env.model(), d, double(o->width) / o->height);
    if (!std::isnan(o->azimuth)) ro.camera.azimuth_deg = o->azimuth;
    if (!std::isnan(o->elevation)) ro.camera.elevation_deg = o->elevation;
    if (!std::isnan(o->distance)) ro.camera.distance = o->distance;
    sim::write_png(sim::render(env.model(), d, ro), o->out);
    std::printf("wrote %s (%dx%d, %s)\n", o->out.c_str(), o->width, o->height,
                env.spec().versioned_id().c_str());
  });
}

}  // namespace bidex::apps
