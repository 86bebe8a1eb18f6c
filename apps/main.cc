// bidex: the command line of the platform. Every command has --help.
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "core/error.h"
#include "core/idle_threads.h"
#include "marl/algorithms.h"
#include "metarl/algorithms.h"
#include "offline/algorithms.h"

BIDEX_REST_IDLE_THREADS_BEFORE_LIBRARIES;

namespace bidex::apps {
namespace {
std::string g_command_line;
}
const std::string& command_line() { return g_command_line; }
void request_gpu_queues(const std::string& device) {
  // 32 hardware queues instead of CUDA's default 8, so that the streams of a GPU pack's scenes
  // (up to twenty) do not wait on each other's work: MT20 packed ran 1.07x (16,384 slots) to
  // 1.41x (2,048) faster (bench/results/pack-connections-h100). Only where the simulation may
  // run on the GPU: every queue costs each process resources on the device, and many processes
  // sharing one GPU (offline learners) do not need them. A value the user set wins.
  if (device != "cpu") setenv("CUDA_DEVICE_MAX_CONNECTIONS", "32", /*overwrite=*/0);
}
void set_command_line(int argc, char** argv) {
  g_command_line = "bidex";
  for (int i = 1; i < argc; ++i) g_command_line += std::string(" ") + argv[i];
}
}  // namespace bidex::apps

int main(int argc, char** argv) {
  bidex::apps::set_command_line(argc, argv);
  // algorithm families outside rl: one registration each
  bidex::metarl::register_algorithms();
  bidex::offline::register_algorithms();
  bidex::marl::register_algorithms();
  CLI::App app{"bidex: bimanual dexterous manipulation benchmark (two Shadow Hands, batched MuJoCo)"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Print help for every command");
  bidex::apps::add_model_command(app);
  bidex::apps::add_sim_command(app);
  bidex::apps::add_bench_command(app);
  bidex::apps::add_info_command(app);
  bidex::apps::add_play_command(app);
  bidex::apps::add_render_command(app);
  bidex::apps::add_train_command(app);
  bidex::apps::add_eval_command(app);
  bidex::apps::add_collect_command(app);
  bidex::apps::add_registry_command(app);
  bidex::apps::add_dataset_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const bidex::Error& e) {  // bad config, model or file: the user can fix it
    std::fprintf(stderr, "bidex: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bidex: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
