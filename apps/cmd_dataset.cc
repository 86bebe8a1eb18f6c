// bidex dataset info | verify | export-d4rl: offline datasets on disk (offline/dataset.h).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "apps/commands.h"
#include "core/files.h"
#include "offline/dataset.h"

namespace bidex::apps {

namespace {

std::string score(double v) {
  if (!std::isfinite(v)) return "-";
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

void print_info(const std::string& dir, const offline::DatasetInfo& i) {
  std::printf("dataset   %s  (%s)\n", i.dataset_id.c_str(), dir.c_str());
  std::printf("task      %s (%s), at most %d steps per episode\n", i.task.c_str(),
              i.task_version.c_str(), i.max_episode_steps);
  std::printf("quality   %s, policy %s (%s), seed %llu\n", i.quality.c_str(), i.policy.c_str(),
              i.algorithm_name.c_str(), static_cast<unsigned long long>(i.seed));
  std::printf("size      %lld steps in %lld episodes (%lld dropped: non-finite values)\n",
              static_cast<long long>(i.total_steps), static_cast<long long>(i.total_episodes),
              static_cast<long long>(i.dropped_episodes));
  std::printf("widths    obs %lld, act %lld\n", static_cast<long long>(i.obs_dim),
              static_cast<long long>(i.act_dim));
  std::printf("scores    ref_min %s (normalised 0), ref_max %s (normalised 100)\n",
              score(i.ref_min_score).c_str(), score(i.ref_max_score).c_str());
  std::printf("checksum  %s (not recomputed: bidex dataset verify)\n", i.checksum.c_str());
  std::printf("code      %s\n", i.code_version.c_str());
  if (!i.command.empty()) std::printf("command   %s\n", i.command.c_str());
  for (auto& s : i.sources) std::printf("source    %s\n", s.c_str());
}

}  // namespace

void add_dataset_command(CLI::App& app) {
  auto* ds = app.add_subcommand(
      "dataset", "Offline datasets (Minari's layout: DIR/data/main_data.hdf5 and "
                 "DIR/data/metadata.json): describe, verify, export to D4RL's layout");
  ds->require_subcommand(1);
  ds->footer("PATH is the dataset folder, its data/ folder or its main_data.hdf5.");

  // info
  {
    struct Opts {
      std::string path;
      bool json = false;
    };
    auto o = std::make_shared<Opts>();
    auto* cmd = ds->add_subcommand(
        "info", "A dataset's metadata: id, task, quality, policy, steps and episodes, widths, "
                "reference scores, checksum; its structure is checked against it (the "
                "checksum is not recomputed: verify)");
    cmd->add_option("path", o->path, "Dataset folder, its data/ folder or main_data.hdf5")
        ->required();
    cmd->add_flag("--json", o->json, "Print metadata.json as it is");
    cmd->footer("Example:\n  bidex dataset info datasets/hand_over/expert-v0");
    cmd->callback([o] {
      const offline::DatasetInfo info = offline::read_info(o->path);
      const std::string dir = offline::dataset_dir(o->path);
      if (o->json)
        std::fputs(read_file(dir + "/data/metadata.json").c_str(), stdout);
      else
        print_info(dir, info);
    });
  }

  // verify
  {
    auto path = std::make_shared<std::string>();
    auto* cmd = ds->add_subcommand(
        "verify", "Check a dataset: metadata.json, the HDF5 structure against it, and the "
                  "SHA-256 of main_data.hdf5 recomputed; prints OK, or fails with status 2 "
                  "naming the problem");
    cmd->add_option("path", *path, "Dataset folder, its data/ folder or main_data.hdf5")
        ->required();
    cmd->footer("Example:\n  bidex dataset verify datasets/hand_over/expert-v0");
    cmd->callback([path] {
      const offline::DatasetInfo info = offline::verify(*path);
      std::printf("OK %s: %lld steps in %lld episodes, %s\n",
                  offline::dataset_dir(*path).c_str(), static_cast<long long>(info.total_steps),
                  static_cast<long long>(info.total_episodes), info.checksum.c_str());
    });
  }

  // export-d4rl
  {
    struct Opts {
      std::string path, out;
    };
    auto o = std::make_shared<Opts>();
    auto* cmd = ds->add_subcommand(
        "export-d4rl", "Write a verified dataset in D4RL's flat layout: one HDF5 file with "
                       "observations, next_observations, actions, rewards, terminals and "
                       "timeouts, and the id, task, quality, checksum and reference scores as "
                       "attributes");
    cmd->add_option("path", o->path, "Dataset folder, its data/ folder or main_data.hdf5")
        ->required();
    cmd->add_option("out", o->out, "The HDF5 file to write (replaced atomically)")->required();
    cmd->footer("Example:\n  bidex dataset export-d4rl datasets/hand_over/expert-v0 "
                "hand_over-expert.hdf5");
    cmd->callback([o] {
      offline::export_d4rl(o->path, o->out);
      const offline::DatasetInfo info = offline::read_info(o->path);
      std::printf("wrote %s: %lld transitions of %s\n", o->out.c_str(),
                  static_cast<long long>(info.total_steps), info.dataset_id.c_str());
    });
  }
}

}  // namespace bidex::apps
