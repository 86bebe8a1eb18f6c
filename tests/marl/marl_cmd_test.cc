// marl through the bidex binary, as a user runs it: bidex info --agents, train --agents (hand,
// finger, a file) into a run folder and the registry, eval, render, resume, and the refusals of
// --agents.
#include "tests/rl/rl_fixture.h"

#include <dirent.h>

#include <nlohmann/json.hpp>

#include "registry/registry.h"

using namespace bidex;
using test::bidex_run;
using test::CommandResult;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

// A tiny multi-agent run of catch_underarm_raise on the CPU.
std::string tiny(const std::string& algo, const std::string& run, const std::string& extra) {
  return "train --task catch_underarm_raise --algo " + algo + " -o env.slots=4 -o env.threads=1 "
         "-o train.steps=64 -o train.save_interval=1 -o train.device=cpu -o "
         "train.torch_threads=1 -o " + algo + ".hidden=[16] --device cpu --run " + q(run) + " " +
         extra;
}

bool exists(const std::string& path) {
  DIR* d = ::opendir(path.c_str());
  if (d) ::closedir(d);
  return d != nullptr;
}

}  // namespace

TEST_CASE("bidex info --agents prints each agent's columns", "[marl][cmd]") {
  CommandResult r = bidex_run("info --task hand_over --agents finger --json");
  INFO(r.out);
  REQUIRE(r.rc == 0);
  const auto j = nlohmann::json::parse(r.out);
  CHECK(j["agent_split"] == "finger");
  REQUIRE(j["agents"].size() == 12);
  CHECK(j["agents"][1]["name"] == "right_ff");
  CHECK(j["agents"][1]["act_columns"] == nlohmann::json({2, 3, 4}));
  CHECK(j["agents"][1]["obs_columns"].size() == 211);
  r = bidex_run("info --task catch_underarm");
  CHECK(r.out.find("right  sees 223 (right, tail), acts on 26: [0, 26)") != std::string::npos);
  r = bidex_run("info --task hand_over --agents fingers");
  CHECK(r.rc == 2);
  CHECK(r.out.find("fingers") != std::string::npos);
}

TEST_CASE("bidex train --agents: runs, eval, render, resume and the registry",
          "[marl][cmd]") {
  test::TaskTempDir tmp;
  const std::string reg = tmp.file("registry.sqlite");
  const std::string groups = tmp.write("groups.yaml", "[[0], [1, 2, 3, 4, 5]]\n");
  struct Case {
    std::string algo, agents, want;
  };
  for (const Case& c : {Case{"mappo", "finger", "finger"}, Case{"happo", groups, "[[0]"},
                        Case{"maddpg", "hand", "hand"}}) {
    const std::string run = tmp.file(c.algo);
    CommandResult r = bidex_run(tiny(c.algo, run, "--agents " + q(c.agents) + " --registry " +
                                                      q(reg)));
    INFO(c.algo << ": " << r.out);
    REQUIRE(r.rc == 0);
    // the split is part of the run's config, so eval, render and resume act the same way
    const std::string cfg = read_file(run + "/config.yaml");
    CHECK(cfg.find("agents: " + c.want) != std::string::npos);
    r = bidex_run("eval --run " + q(run) + " --episodes 4 --threads 1");
    INFO(r.out);
    CHECK(r.rc == 0);
    CHECK(r.out.find("mean return") != std::string::npos);
    r = bidex_run("render --run " + q(run) + " --out " + q(run + "/frames") +
                  " --max-frames 2 --width 64 --height 48");
    INFO(r.out);
    CHECK(r.rc == 0);
    r = bidex_run("train --resume " + q(run) + " --no-registry -o train.steps=128");
    CHECK(r.rc == 2);  // --resume takes no overrides
    r = bidex_run("train --resume " + q(run) + " --registry " + q(reg));
    INFO(r.out);
    CHECK(r.rc == 0);
  }
  registry::Registry db(reg);
  CHECK(db.runs().size() >= 3);
}

TEST_CASE("bidex train --agents refusals: other algorithms, resume, a bad file",
          "[marl][cmd]") {
  test::TaskTempDir tmp;
  const std::string run = tmp.file("run");
  CommandResult r = bidex_run(tiny("ppo", run, "--agents finger --no-registry"));
  CHECK(r.rc == 2);
  CHECK(r.out.find("--agents goes with a multi-agent algorithm") != std::string::npos);
  const std::string bad = tmp.write("bad.yaml", "- {name: a, act: [right.joints]}\n"
                                                "- {name: b, act: [left.joints]}\n");
  r = bidex_run(tiny("mappo", run, "--agents " + q(bad) + " --no-registry"));
  INFO(r.out);
  CHECK(r.rc == 2);
  CHECK(r.out.find("bad.yaml") != std::string::npos);
  CHECK(r.out.find("columns [20, 26), [46, 52)") != std::string::npos);
  CHECK_FALSE(exists(run));  // nothing written
  r = bidex_run(tiny("mappo", run, "--agents nowhere.yaml --no-registry"));
  CHECK(r.rc == 2);
  CHECK(r.out.find("nowhere.yaml") != std::string::npos);
  r = bidex_run("train --resume " + q(run) + " --agents hand");
  CHECK(r.rc == 2);
  CHECK(r.out.find("--agents") != std::string::npos);
}
