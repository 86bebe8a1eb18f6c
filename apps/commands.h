// The subcommands of `bidex`; each adds itself to the CLI11 app and runs from its callback.
#pragma once

namespace CLI {
class App;
}

namespace bidex::registry {
class Registry;
}

#include <string>

namespace bidex::apps {

// `path` made absolute (realpath), or as given where it does not exist.
std::string absolute(const std::string& path);

// Records the dataset at `path` (offline/dataset.h) in `reg` and returns its checksum (offline
// runs, bidex collect; apps/cmd_train.cc).
std::string record_dataset(registry::Registry& reg, const std::string& path);

// The command line this process was started with, for results files.
const std::string& command_line();
void set_command_line(int argc, char** argv);

// Asks CUDA for 32 hardware queues (CUDA_DEVICE_MAX_CONNECTIONS, unless set) when `device`, a
// command's --device, is not "cpu". Call it first in the callback of a command that may step a
// GPU pack: CUDA reads the setting when the process's context is made.
void request_gpu_queues(const std::string& device);

void add_model_command(CLI::App& app);  // bidex model: write standalone MJCF of the hands
void add_sim_command(CLI::App& app);    // bidex sim: step the two-hand scene, random actions
void add_bench_command(CLI::App& app);  // bidex bench sim|soak|physics|task
void add_info_command(CLI::App& app);   // bidex info: a task's spec and named slices
void add_play_command(CLI::App& app);   // bidex play: run a task with random/zero actions
void add_render_command(CLI::App& app); // bidex render: a task's scene, or a policy's episode
void add_train_command(CLI::App& app);  // bidex train: PPO with a run folder, --resume
void add_eval_command(CLI::App& app);   // bidex eval: a trained policy's return and success
void add_collect_command(CLI::App& app);  // bidex collect: offline datasets
void add_registry_command(CLI::App& app);  // bidex registry list|add-task|scores|reference|report
void add_dataset_command(CLI::App& app);   // bidex dataset info|verify|export-d4rl

}  // namespace bidex::apps
