// apps/cmd_task: `bidex info --task ID [--json]` and `bidex play`, run as the real binary.
#include <cstdio>
#include <string>

#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "sim/cuda_driver.h"
#include "tests/run_command.h"
#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

TEST_CASE("bidex info --task catch_underarm --json prints the spec with every slice",
          "[tasks][apps]") {
  CommandResult r = bidex_run("info --task catch_underarm --json");
  INFO(r.out);
  REQUIRE(r.rc == 0);
  const auto j = nlohmann::json::parse(r.out);
  const auto& sp = tasks::find_task("catch_underarm").spec();
  CHECK(j.at("id") == "catch_underarm");
  CHECK(j.at("obs_dim") == 422);
  CHECK(j.at("act_dim") == 52);
  CHECK(j.at("episode_length") == 75);
  CHECK(j.at("base") == "free");
  CHECK(j.at("default_config") == tasks::default_task_config("catch_underarm"));
  REQUIRE(j.at("obs").size() == sp.obs.slices().size());
  for (size_t i = 0; i < sp.obs.slices().size(); ++i) {
    const auto& s = sp.obs.slices()[i];
    const auto& js = j.at("obs")[i];
    INFO("slice " << s.name);
    CHECK(js.at("name") == s.name);
    CHECK(js.at("start") == s.start);
    CHECK(js.at("size") == s.size);
    CHECK(js.at("end") == s.end());
    CHECK(js.at("goal") == s.goal);
  }
  // the paper's rows at both ends of the list
  CHECK(j.at("obs")[0].at("name") == "right.dof_pos");
  CHECK(j.at("obs").back().at("name") == "goal.rot_diff");
  CHECK(j.at("obs").back().at("start") == 418);
  REQUIRE(j.at("act").size() == 6);
  CHECK(j.at("act")[4].at("name") == "left.base_translation");
  CHECK(j.at("act")[4].at("start") == 46);
  REQUIRE(j.at("agents").size() == 2);
  CHECK(j.at("agents")[0].at("name") == "right");
  REQUIRE(j.at("reward_terms").size() == 4);
  CHECK(j.at("reward_terms")[0].at("name") == "pose");
}

TEST_CASE("bidex info --task prints the layout as text", "[tasks][apps]") {
  CommandResult r = bidex_run("info --task hand_over");
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK(contains(r.out, "hand_over-v1"));
  CHECK(contains(r.out, "observation (398)"));
  CHECK(contains(r.out, "action (40)"));
  CHECK(contains(r.out, "object.pose"));
  CHECK(contains(r.out, "[374, 381)"));
  CHECK(contains(r.out, "right  sees 211 (right, tail), acts on 20: [0, 20) (right.joints)"));
}

TEST_CASE("bidex play --task hand_over --policy zero prints every reward term",
          "[tasks][apps]") {
  CommandResult r = bidex_run("play --task hand_over --policy zero --steps 20 --slots 2");
  INFO(r.out);
  REQUIRE(r.rc == 0);
  for (auto& t : tasks::find_task("hand_over").spec().reward_terms) CHECK(contains(r.out, t.name));
  CHECK(contains(r.out, "reward (sum)"));
  CHECK(contains(r.out, "simulation faults: 0"));
  CHECK(contains(r.out, "2 slots"));
}

TEST_CASE("bidex play writes its statistics as JSON", "[tasks][apps]") {
  TaskTempDir dir;
  const std::string out = dir.file("play.json");
  CommandResult r = bidex_run("play --task two_catch_underarm --policy random --steps 10 --slots 3 --json '" +
                       out + "'");
  INFO(r.out);
  REQUIRE(r.rc == 0);
  const auto j = nlohmann::json::parse(read_file(out));
  CHECK(j.at("task") == "two_catch_underarm-v1");
  CHECK(j.at("slots") == 3);
  CHECK(j.at("steps") == 10);
  for (const char* t : {"pose_object1", "pose_object2", "goal_bonus", "fall_penalty",
                        "action_penalty", "reward (sum)"})
    CHECK(j.at("terms").contains(t));
  CHECK(j.at("episodes").at("faults") == 0);
}

TEST_CASE("bidex play picks its device and says why, and a GPU it cannot have is a clear error",
          "[tasks][apps]") {
  // auto: pen's stages do not run on the GPU, so the CPU, whatever the machine has
  CommandResult r = bidex_run("play --task pen --policy zero --steps 2 --slots 2 --json /dev/null");
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK(contains(r.out, "on the CPU"));
  if (!sim::cuda::driver_available()) {
    CommandResult g = bidex_run("play --task hand_over --steps 2 --slots 2 --device cuda");
    INFO(g.out);
    CHECK(g.rc == 2);
    CHECK(contains(g.out, "no NVIDIA driver"));
    CHECK(contains(g.out, "--device cpu"));
    CommandResult a = bidex_run("play --task hand_over --policy zero --steps 2 --slots 2");
    CHECK(a.rc == 0);
    CHECK(contains(a.out, "on the CPU"));
  }
  CommandResult bad = bidex_run("play --task hand_over --steps 2 --device gpu");
  CHECK(bad.rc != 0);
  CHECK(contains(bad.out, "gpu not in {auto,cpu,cuda}"));
}

TEST_CASE("bidex play with an unknown task or a bad YAML exits 2 naming the problem",
          "[tasks][apps][config]") {
  CommandResult r = bidex_run("play --task nope --steps 1");
  INFO(r.out);
  CHECK(r.rc == 2);
  CHECK(contains(r.out, "'nope'"));
  CHECK(contains(r.out, "catch_underarm"));  // the known ids are listed
  CommandResult info = bidex_run("info --task nope");
  CHECK(info.rc == 2);
  CHECK(contains(info.out, "'nope'"));

  TaskTempDir dir;
  const std::string yaml = dir.write(
      "bad.yaml", set_value(default_yaml("catch_underarm"), "object_position_noise", "-1"));
  CommandResult bad = bidex_run("play --task catch_underarm --steps 1 --config '" + yaml + "'");
  INFO(bad.out);
  CHECK(bad.rc == 2);
  CHECK(contains(bad.out, yaml));
  CHECK(contains(bad.out, "reset.object_position_noise"));
}
