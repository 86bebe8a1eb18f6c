// bidex collect: offline datasets of a task at a quality (offline/collect.h), or medium-expert
// as the merge of a medium and an expert dataset; each recorded in the registry.
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "apps/commands.h"
#include "core/error.h"
#include "offline/collect.h"
#include "offline/dataset.h"
#include "registry/registry.h"

namespace bidex::apps {

void add_collect_command(CLI::App& app) {
  struct Opts {
    offline::CollectOptions c;
    std::vector<std::string> merge;
    std::string registry;
    bool no_registry = false, mean = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "collect", "Write an offline dataset (HDF5, Minari's layout) of a task: a random policy's, "
                 "a run's medium or expert policy's, or medium-expert merged from two datasets");
  cmd->add_option("--quality", o->c.quality,
                  "random, medium (the run's checkpoint nearest half its newest's return, or "
                  "--checkpoint), expert (its newest), or medium-expert (with --merge); replay "
                  "datasets come from bidex train --record-replay")
      ->required()
      ->check(CLI::IsMember(offline::qualities()));
  cmd->add_option("--out", o->c.out, "The new dataset's folder")->required();
  cmd->add_option("--task", o->c.task, "Task id (random; with --run it must be the run's)");
  cmd->add_option("--run", o->c.run_dir, "Run folder of bidex train whose policy acts");
  cmd->add_option("--checkpoint", o->c.checkpoint, "Its checkpoint (default: see --quality)");
  cmd->add_option("--expert", o->c.expert_run,
                  "Run whose newest checkpoint's return is the normalised score's 100 (default: "
                  "--run; a random dataset without it has no upper reference)");
  cmd->add_option("--merge", o->merge,
                  "medium-expert: the medium and the expert dataset, in this order")
      ->expected(2);
  cmd->add_option("--steps", o->c.steps, "Transitions, rounded up to whole episodes")
      ->capture_default_str();
  cmd->add_option("--slots", o->c.slots, "Parallel slots")->capture_default_str();
  cmd->add_option("--seed", o->c.seed, "Seed of the pack and the actions")->capture_default_str();
  cmd->add_option("--threads", o->c.threads, "CPU simulation threads (0: all cores)");
  cmd->add_option("--device", o->c.device,
                  "Where the pack steps: cpu, cuda (MuJoCo Warp) or auto")
      ->check(CLI::IsMember({"auto", "cpu", "cuda"}))
      ->capture_default_str();
  cmd->add_option("--ref-episodes", o->c.ref_episodes,
                  "Episodes of each reference evaluation (random, expert), on the CPU")
      ->capture_default_str();
  cmd->add_flag("--mean", o->mean,
                "Act with the policy's mean action (default: its sampled actions, as the "
                "original collected)");
  cmd->add_option("--registry", o->registry, "Registry the dataset is recorded in");
  cmd->add_flag("--no-registry", o->no_registry, "Do not record the dataset in a registry");
  cmd->footer(
      "Examples:\n"
      "  bidex collect --task catch_underarm_raise --quality random --steps 20000 \\\n"
      "      --out datasets/catch_underarm_raise/random-v0\n"
      "  bidex collect --run runs/hand_over-ppo-X --quality expert --out datasets/hand_over/expert-v0\n"
      "  bidex collect --run runs/hand_over-ppo-X --quality medium --out datasets/hand_over/medium-v0\n"
      "  bidex collect --quality medium-expert --merge datasets/hand_over/medium-v0 \\\n"
      "      datasets/hand_over/expert-v0 --out datasets/hand_over/medium-expert-v0\n"
      "Then: bidex dataset info DIR; bidex train --algo td3bc --dataset DIR");
  cmd->callback([o] {
    if (o->no_registry && !o->registry.empty())
      throw Error("collect: --registry and --no-registry contradict each other");
    o->c.command = command_line();
    o->c.sample = !o->mean;
    offline::DatasetInfo d;
    if (o->c.quality == "medium-expert") {
      if (o->merge.size() != 2)
        throw Error("collect: --quality medium-expert merges two datasets: --merge MEDIUM EXPERT");
      if (!o->c.run_dir.empty() || !o->c.task.empty())
        throw Error("collect: --quality medium-expert takes its task from --merge; drop --run "
                    "and --task");
      const offline::DatasetInfo medium = offline::read_info(o->merge[0]);
      offline::DatasetInfo info;
      info.quality = "medium-expert";
      info.dataset_id = medium.task + "/medium-expert-v0";
      info.ref_min_score = medium.ref_min_score;
      info.ref_max_score = medium.ref_max_score;
      info.policy = "merge";
      info.algorithm_name = medium.algorithm_name;
      info.command = o->c.command;
      d = offline::merge(o->merge, o->c.out, info);
    } else {
      if (!o->merge.empty()) throw Error("collect: --merge goes with --quality medium-expert");
      d = offline::collect(o->c);
    }
    std::printf("dataset %s: %s, %lld steps in %lld episodes, %s\n", o->c.out.c_str(),
                d.dataset_id.c_str(), static_cast<long long>(d.total_steps),
                static_cast<long long>(d.total_episodes), d.checksum.c_str());
    auto ref = [](double v) {
      char b[32];
      std::snprintf(b, sizeof b, "%.4g", v);
      return std::isfinite(v) ? std::string(b) : std::string("n/a");
    };
    std::printf("references: random %s, expert %s; policy %s\n", ref(d.ref_min_score).c_str(),
                ref(d.ref_max_score).c_str(), d.policy.c_str());
    if (!o->no_registry) {
      registry::Registry reg(o->registry.empty() ? registry::default_path() : o->registry);
      record_dataset(reg, o->c.out);
      std::printf("registry %s: dataset %s\n", reg.path().c_str(), d.checksum.c_str());
    }
  });
}

}  // namespace bidex::apps
