// bidex info / play: a task's spec with every named slice, and a policy-free run of a task that
// reports each reward term.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "core/error.h"
#include "core/files.h"
#include "core/progress.h"
#include "marl/agents.h"
#include "marl/spec_json.h"
#include "tasks/env.h"
#include "tasks/registry.h"
#include "tasks/warp_env.h"

namespace bidex::apps {

using nlohmann::json;

namespace {

std::string task_ids() {
  std::string s;
  for (auto& e : tasks::task_registry()) s += (s.empty() ? "" : ", ") + e.spec().id;
  return s;
}

void print_layout(const char* title, const tasks::Layout& l) {
  std::printf("%s (%d):\n", title, l.dim());
  for (auto& s : l.slices())
    std::printf("  [%3d, %3d)  %-26s %s%s\n", s.start, s.end(), s.name.c_str(),
                s.goal ? "(goal) " : "", s.doc.c_str());
}

}  // namespace

void add_info_command(CLI::App& app) {
  struct Opts {
    std::string task, agents = "hand";
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("info", "Print a task's spec: identity, human age, difficulty, "
                                         "episode length, every named observation and action "
                                         "slice, agents and reward terms");
  cmd->add_option("--task", o->task, "Task id (" + task_ids() + ")")->required();
  cmd->add_flag("--json", o->json, "Print JSON instead of text");
  cmd->add_option("--agents", o->agents,
                  "The multi-agent split to show: hand, finger, or a YAML file of agents "
                  "(bidex train --agents)")
      ->capture_default_str();
  cmd->footer("Examples:\n  bidex info --task catch_underarm\n  bidex info --task hand_over --json\n"
              "  bidex info --task hand_over --agents finger");
  cmd->callback([o] {
    const tasks::TaskSpec& sp = tasks::find_task(o->task).spec();
    const marl::AgentSplit split = marl::agents_from_arg(sp, o->agents);
    if (o->json) {
      std::printf("%s\n", marl::task_spec_json(sp, split).dump(2).c_str());
      return;
    }
    std::printf("%s  %s (original: %s)\n", sp.versioned_id().c_str(), sp.paper_name.c_str(),
                sp.original_name.c_str());
    std::printf("  human age: %s%s   difficulty: %s\n",
                sp.age.text == "adult" ? "adult" : (sp.age.text + " months").c_str(),
                sp.age.from_commented_row ? " (a row the paper comments out)" : "",
                tasks::difficulty_name(sp.difficulty));
    std::printf("  skill: %s\n", sp.skill.c_str());
    std::printf("  episode: %d control steps (%.2f s at 60 Hz); bases: %s\n", sp.episode_length,
                sp.episode_length / 60.0, sp.free_base ? "free (6-DoF, pushed by forces)" : "fixed");
    std::printf("  default config: %s\n\n", tasks::default_task_config(sp.id).c_str());
    print_layout("observation", sp.obs);
    std::printf("\n");
    print_layout("action", sp.act);
    std::printf("\nagents (multi-agent split '%s'; the critic sees all %d values):\n%s",
                split.kind.c_str(), sp.obs.dim(), marl::describe(split).c_str());
    std::printf("\nreward = sum of terms:\n");
    for (auto& t : sp.reward_terms) std::printf("  %-16s %s\n", t.name.c_str(), t.doc.c_str());
  });
}

void add_play_command(CLI::App& app) {
  struct Opts {
    std::string task, policy = "random", config, json_out, device = "auto";
    int steps = 300, slots = 16, threads = 0;
    uint64_t seed = 1;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand(
      "play", "Run a task without learning (random or zero actions) and print statistics of "
              "each reward term, episode returns, success rate and faults");
  cmd->add_option("--task", o->task, "Task id (" + task_ids() + ")")->required();
  cmd->add_option("--policy", o->policy, "random (uniform in [-1, 1]) or zero")
      ->check(CLI::IsMember({"random", "zero"}))->capture_default_str();
  cmd->add_option("--steps", o->steps, "Control steps per slot")->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--slots", o->slots, "Parallel worlds")->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads (0: all cores)")->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed")->capture_default_str();
  cmd->add_option("--config", o->config, "Task YAML (default: the task's own)");
  cmd->add_option("--device", o->device,
                  "cpu (MuJoCo, all cores), cuda (MuJoCo Warp on the GPU), or auto: cuda when "
                  "there is a GPU and the task's stages run there")
      ->check(CLI::IsMember({"auto", "cpu", "cuda"}))->capture_default_str();
  cmd->add_option("--json", o->json_out, "Also write the statistics as JSON to this file");
  cmd->footer("Example:\n  bidex play --task catch_underarm --policy random --steps 300");
  cmd->callback([o] {
    auto task = tasks::make_task(o->task, o->config);
    std::string why;
    const std::string device = tasks::choose_device(o->device, *task, &why);
    // the two paths behind one loop: step with host actions, then read terms and rewards
    std::unique_ptr<tasks::TaskEnv> cpu;
    std::unique_ptr<tasks::WarpTaskEnv> gpu;
    if (device == "cuda") {
      tasks::WarpEnvOptions wo;
      wo.nslot = o->slots;
      wo.seed = o->seed;
      gpu = std::make_unique<tasks::WarpTaskEnv>(std::move(task), wo);
    } else {
      tasks::EnvOptions eo;
      eo.nslot = o->slots;
      eo.threads = o->threads;
      eo.seed = o->seed;
      cpu = std::make_unique<tasks::TaskEnv>(std::move(task), eo);
    }
    const tasks::TaskSpec& sp = cpu ? cpu->spec() : gpu->spec();
    const int nslot = o->slots, nt = cpu ? cpu->nterms() : gpu->nterms();
    const int act_dim = cpu ? cpu->act_dim() : gpu->act_dim();
    const std::string config_file = cpu ? cpu->task().config_file() : gpu->task().config_file();
    std::printf("%s: %d slots on %s (%s), %s policy, %d steps, config %s\n",
                sp.versioned_id().c_str(), nslot,
                cpu ? ("the CPU, " + std::to_string(cpu->threads()) + " threads").c_str()
                    : "the GPU (MuJoCo Warp)",
                why.c_str(), o->policy.c_str(), o->steps, config_file.c_str());
    // per term (and the reward as the last column): sum, sum of squares, min, max
    std::vector<double> sum(nt + 1, 0), sq(nt + 1, 0), lo(nt + 1, INFINITY), hi(nt + 1, -INFINITY);
    std::vector<float> actions(static_cast<size_t>(nslot) * act_dim, 0.f), terms, reward;
    std::mt19937_64 rng(o->seed);
    Progress bar("play", static_cast<int64_t>(o->steps) * nslot, "slot-steps");
    for (int i = 0; i < o->steps; ++i) {
      if (o->policy == "random") tasks::random_actions(actions, rng);
      if (cpu) {
        cpu->step(actions);
        terms = cpu->terms;
        reward = cpu->reward;
      } else {
        gpu->step(actions);
        terms = gpu->download<float>("terms");
        reward = gpu->download<float>("reward");
      }
      for (int s = 0; s < nslot; ++s)
        for (int k = 0; k <= nt; ++k) {
          const double x = k < nt ? terms[static_cast<size_t>(s) * nt + k] : reward[s];
          sum[k] += x;
          sq[k] += x * x;
          lo[k] = std::min(lo[k], x);
          hi[k] = std::max(hi[k], x);
        }
      bar.update(static_cast<int64_t>(i + 1) * nslot);
    }
    bar.finish();
    const double n = static_cast<double>(o->steps) * nslot;
    auto ep = cpu ? cpu->take_stats() : gpu->take_stats();
    json out = {{"task", sp.versioned_id()}, {"policy", o->policy}, {"slots", nslot},
                {"steps", o->steps}, {"seed", o->seed}, {"device", device}};
    std::printf("\nper slot-step (%.0f of them):\n  %-16s %11s %11s %11s %11s %14s\n", n, "term",
                "mean", "std", "min", "max", "episode mean");
    for (int k = 0; k <= nt; ++k) {
      const std::string name = k < nt ? sp.reward_terms[k].name : "reward (sum)";
      const double mean = sum[k] / n, sd = std::sqrt(std::max(0.0, sq[k] / n - mean * mean));
      const double per_ep = ep.episodes == 0 ? NAN
                            : k < nt      ? ep.term_sums[k] / ep.episodes
                                          : ep.return_sum / ep.episodes;
      std::printf("  %-16s %11.5g %11.5g %11.5g %11.5g %14.5g\n", name.c_str(), mean, sd, lo[k],
                  hi[k], per_ep);
      out["terms"][name] = {{"mean", mean}, {"std", sd}, {"min", lo[k]}, {"max", hi[k]},
                            {"episode_mean", per_ep}};
    }
    const double eps = static_cast<double>(ep.episodes);
    std::printf("\nepisodes finished: %lld (terminated %lld, truncated %lld); mean return %.4g, "
                "mean length %.1f, success rate %.3f; simulation faults: %lld\n",
                static_cast<long long>(ep.episodes), static_cast<long long>(ep.terminated),
                static_cast<long long>(ep.truncated), eps ? ep.return_sum / eps : NAN,
                eps ? ep.length_sum / eps : NAN, eps ? ep.successes / eps : NAN,
                static_cast<long long>(ep.faults));
    if (gpu && !gpu->backend().room_advice().empty()) {
      std::printf("%s\n", gpu->backend().room_advice().c_str());
      out["room_advice"] = gpu->backend().room_advice();
    }
    out["episodes"] = {{"count", ep.episodes}, {"terminated", ep.terminated},
                       {"truncated", ep.truncated}, {"faults", ep.faults},
                       {"mean_return", eps ? ep.return_sum / eps : 0.0},
                       {"mean_length", eps ? ep.length_sum / eps : 0.0},
                       {"success_rate", eps ? ep.successes / eps : 0.0}};
    if (!o->json_out.empty()) write_file_atomic(o->json_out, out.dump(2) + "\n");
  });
}

}  // namespace bidex::apps
