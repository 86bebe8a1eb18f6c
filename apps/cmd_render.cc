// bidex render: a picture of a task's initial scene, or the frames (and an MP4 when ffmpeg is
// installed) of one episode of a trained policy, drawn headless by MuJoCo's renderer.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include "apps/commands.h"
#include "apps/programs.h"
#include "core/error.h"
#include "rl/trainer.h"
#include "sim/render.h"
#include "taskpack/pack.h"
#include "tasks/env.h"
#include "tasks/registry.h"

namespace bidex::apps {

void add_render_command(CLI::App& app) {
  struct Opts {
    std::string task, out, config, run, checkpoint, split, entry;
    int width = 800, height = 600, max_frames = 1000, fps = 30;
    uint64_t seed = 1;
    double azimuth = NAN, elevation = NAN, distance = NAN;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "render", "Render a task's initial scene (after one reset) to a PNG, or with --run the "
                "frames of one episode of a trained policy (and episode.mp4 when ffmpeg is on "
                "PATH), headless (MuJoCo's renderer in an offscreen OpenGL context; backend: " +
                    std::string(sim::render_backend()) + ")");
  cmd->add_option("--task", o->task, "Task id (a scene picture)");
  cmd->add_option("--run", o->run, "Run folder of bidex train (an episode of its policy)");
  cmd->add_option("--checkpoint", o->checkpoint, "With --run: checkpoint (default: the newest)");
  cmd->add_option("--out,-o", o->out,
                  "PNG file to write (--task), or folder for frame_NNNNN.png and episode.mp4 "
                  "(--run)")->required();
  cmd->add_option("--max-frames", o->max_frames, "With --run: stop after this many frames")
      ->check(CLI::Range(1, 100000))->capture_default_str();
  cmd->add_option("--fps", o->fps, "With --run: frame rate of the MP4")
      ->check(CLI::Range(1, 240))->capture_default_str();
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
  cmd->add_option("--entry", o->entry,
                  "With --run of a suite run: the suite entry (task label) to show (default: the "
                  "split's first)");
  cmd->add_option("--split", o->split,
                  "With --run of a suite run: train or test (default train; a meta-RL run shows "
                  "its policy before adaptation)");
  cmd->footer("Examples:\n  bidex render --task catch_underarm --out catch_underarm.png\n"
              "  bidex render --run runs/hand_over-ppo-20261122-120000-s0 --out frames/\n"
              "  bidex render --run runs/mt4 --entry hand_over --out frames/");
  cmd->callback([o] {
    if (o->run.empty() == o->task.empty())
      throw Error("render: give exactly one of --task ID (a scene) and --run DIR (an episode)");
    if (!o->run.empty()) {
      rl::LoadedPolicy policy(o->run, o->checkpoint);
      const rl::TrainConfig& c = policy.config();
      // the run's own pack, one slot per entry (a task run: its task alone), so that the policy
      // sees the rows it was trained on (padding, one-hot ids, masked goals); one entry is drawn
      if (c.suite.empty() && (!o->entry.empty() || !o->split.empty()))
        throw Error("render: --entry and --split go with a suite run; " + o->run +
                    " trained on task " + c.task);
      const taskpack::PackSpec ps = rl::eval_pack(c, o->split.empty() ? "train" : o->split, 1,
                                                  false);
      int g = 0;
      if (!o->entry.empty()) {
        std::string labels;
        g = -1;
        for (int i = 0; i < static_cast<int>(ps.entries.size()); ++i) {
          const auto& e = ps.entries[i];
          const std::string label = e.label.empty() ? e.task : e.label;
          if (label == o->entry) g = i;
          labels += (labels.empty() ? "" : ", ") + label;
        }
        if (g < 0)
          throw ConfigError("--entry", "entry", "an entry of " + c.suite + " (" + labels + ")",
                            "'" + o->entry + "'");
      }
      taskpack::TaskPack pack(ps, rl::run_pack_options(c, o->seed, 1));
      policy.check_fits(pack, c.target() + " now");
      pack.reset();
      tasks::TaskEnv& env = pack.group(g);
      const int slot = pack.group_begin(g);
      sim::RenderOptions ro;
      ro.width = o->width;
      ro.height = o->height;
      ro.camera =
          sim::framing_camera(env.model(), env.batch().data(0), double(o->width) / o->height);
      if (!std::isnan(o->azimuth)) ro.camera.azimuth_deg = o->azimuth;
      if (!std::isnan(o->elevation)) ro.camera.elevation_deg = o->elevation;
      if (!std::isnan(o->distance)) ro.camera.distance = o->distance;
      std::vector<float> act(size_t(pack.nslot()) * pack.act_dim());
      double ret = 0;
      int frame = 0;
      auto write = [&] {
        char name[32];
        std::snprintf(name, sizeof name, "/frame_%05d.png", frame++);
        sim::write_png(sim::render(env.model(), env.batch().data(0), ro), o->out + name);
      };
      write();
      bool success = false;
      while (frame < o->max_frames) {
        policy.act(pack.obs.data(), pack.nslot(), act.data());
        pack.step(act);
        ret += env.reward[0];  // unscaled: the task's own reward
        const bool done = pack.terminated[slot] || pack.truncated[slot];
        if (done) {  // the last frame shows the state the episode ended in
          success = pack.success[slot];
          break;
        }
        write();
      }
      std::printf("wrote %d frames to %s (%s, checkpoint %s): return %.4g, success %d\n", frame,
                  o->out.c_str(), pack.label(g).c_str(), policy.checkpoint().c_str(), ret,
                  int(success));
      const std::string ffmpeg = find_on_path("ffmpeg");
      if (ffmpeg.empty()) {
        std::printf("ffmpeg is not on PATH: no episode.mp4 (the frames are PNG files)\n");
        return;
      }
      const std::string mp4 = o->out + "/episode.mp4", tmp = o->out + "/.episode.tmp.mp4";
      const int rc = run_program({ffmpeg, "-y", "-loglevel", "error", "-framerate",
                                  std::to_string(o->fps), "-i", o->out + "/frame_%05d.png",
                                  "-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                                  tmp});
      if (rc != 0 || std::rename(tmp.c_str(), mp4.c_str()) != 0) {
        ::unlink(tmp.c_str());
        throw Error("ffmpeg (" + ffmpeg + ") failed to write " + mp4 + " (exit " +
                    std::to_string(rc) + "); the frames are in " + o->out);
      }
      std::printf("wrote %s\n", mp4.c_str());
      return;
    }
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
