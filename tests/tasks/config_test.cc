// tasks/registry + load_catch_params + objects: unknown task ids and bad task YAML files are
// ConfigErrors naming the file, the key path, what was expected and what was found; a broken
// MJCF object is a ModelError naming the scene; a valid user MJCF object builds and steps; each
// task's GPU room exceeds the constraint rows its runs have needed.
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "sim/hand_spec.h"
#include "sim/physics.h"
#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

namespace {

// A ConfigError names the file (maybe with ":line"), the exact key path, and contains the
// expected and actual fragments, in its fields and in what().
void check_error(const ConfigError& e, const std::string& file, const std::string& key,
                 const std::string& expected, const std::string& actual) {
  const std::string what = e.what();
  INFO("what(): " << what);
  CHECK(e.file().rfind(file, 0) == 0);
  CHECK(contains(what, file));
  CHECK(e.key() == key);
  CHECK(contains(what, key));
  CHECK(contains(e.expected(), expected));
  CHECK(contains(what, "expected " + e.expected()));
  CHECK(contains(e.actual(), actual));
  CHECK(contains(what, "got " + e.actual()));
}

struct BadYaml {
  const char* what;
  const char* task;
  std::function<std::string(std::string)> edit;
  const char* key;
  const char* expected;
  const char* actual;
};

const std::string kSecondObject = "  - {start: [0, -0.78, 0.55], goal: [0, -0.38, 0.54]}\n";

const std::vector<BadYaml>& bad_yamls() {
  static const std::vector<BadYaml> cases = {
      {"an unknown top-level key", "catch_underarm",
       [](std::string t) { return t + "colour: red\n"; }, "colour", "one of the keys {",
       "unknown key 'colour'"},
      {"an unknown key inside a section", "hand_over",
       [](std::string t) { return edit_once(t, "reset:\n", "reset:\n  jitter: 1\n"); },
       "reset.jitter", "hand_dof_noise", "unknown key 'jitter'"},
      {"a missing key", "catch_underarm",
       [](std::string t) { return remove_key(t, "hand_dof_noise"); }, "reset.hand_dof_noise",
       "a value for the required key", "none"},
      {"a missing top-level key", "catch_abreast",
       [](std::string t) { return remove_key(t, "episode_length"); }, "episode_length",
       "a value for the required key", "none"},
      {"a wrong type: text for an integer", "catch_underarm",
       [](std::string t) { return set_value(t, "episode_length", "many"); }, "episode_length",
       "an integer", "many"},
      {"a wrong type: a number for a flag", "two_catch_underarm",
       [](std::string t) { return set_value(t, "random_goal_rotation", "3"); },
       "reset.random_goal_rotation", "true or false", "3"},
      {"a wrong type: two numbers for a position", "catch_underarm",
       [](std::string t) {
         return edit_once(t, "right: {pos: [0, 0, 0.5],", "right: {pos: [0, 0.5],");
       },
       "hands.right.pos", "a list of 3 numbers", "[0, 0.5]"},
      {"a negative position noise", "catch_underarm",
       [](std::string t) { return set_value(t, "object_position_noise", "-0.01"); },
       "reset.object_position_noise", "a noise in [0, 1] m", "-0.01"},
      {"a negative joint noise", "hand_over",
       [](std::string t) { return set_value(t, "hand_dof_noise", "-0.2"); },
       "reset.hand_dof_noise", "[0, 1]", "-0.2"},
      {"a zero episode length", "hand_over",
       [](std::string t) { return set_value(t, "episode_length", "0"); }, "episode_length",
       "an episode length > 0", "0"},
      {"a positive fall penalty", "catch_underarm",
       [](std::string t) { return set_value(t, "fall_penalty", "5"); }, "reward.fall_penalty",
       "a penalty <= 0", "5"},
      {"two objects for a one-object task", "catch_underarm",
       [](std::string t) {
         const std::string one = "  - {start: [0, -0.39, 0.55], goal: [0, -0.79, 0.54]}\n";
         return edit_once(t, one, one + kSecondObject);
       },
       "objects", "1 object(s) for catch_underarm", "2 entries"},
      {"one object for two_catch_underarm", "two_catch_underarm",
       [](std::string t) { return edit_once(t, kSecondObject, ""); }, "objects",
       "2 object(s) for two_catch_underarm", "1 entries"},
      {"a base section in hand_over (fixed bases)", "hand_over",
       [](std::string t) { return t + "base:\n  force_scale: 0.05\n  torque_scale: 0.5\n"; },
       "base", "no 'base' section: hand_over has fixed bases", "a base section"},
      {"no base section in a free-base task", "catch_underarm",
       [](std::string t) {
         return remove_key(remove_key(remove_key(t, "force_scale"), "torque_scale"), "base");
       },
       "base", "a value for the required key", "none"},
      {"a drift limit in hand_over (fixed bases)", "hand_over",
       [](std::string t) { return set_value(t, "max_root_drift", "0.1"); }, "termination",
       "no drift limits: hand_over has fixed bases", "max_*_drift > 0"},
      {"a palm drift limit without anchors", "catch_underarm",
       [](std::string t) { return set_value(t, "max_palm_drift", "0.1"); },
       "termination.palm_anchors", "a value for the required key", "none"},
      {"an unknown object type", "catch_underarm",
       [](std::string t) { return set_value(t, "object", "banana"); }, "object",
       "one of egg, block, pen, ball, mjcf", "'banana'"},
      {"an unknown object type in the map form", "hand_over",
       [](std::string t) { return set_value(t, "object", "{type: banana, density: 300}"); },
       "object.type", "one of egg, block, pen, ball, mjcf", "'banana'"},
      {"a ball with three sizes", "catch_underarm",
       [](std::string t) { return set_value(t, "object", "{type: ball, size: [0.03, 0.03, 0.03]}"); },
       "object.size", "1 numbers (radius)", "[0.03, 0.03, 0.03]"},
      {"a negative density", "catch_underarm",
       [](std::string t) { return set_value(t, "object", "{type: block, density: -500}"); },
       "object.density", "a density > 0", "-500"},
      {"an mjcf object whose file is missing", "catch_underarm",
       [](std::string t) { return set_value(t, "object", "{type: mjcf, file: not_there.xml}"); },
       "object.file", "a readable MJCF body file", "not_there.xml"},
      {"an mjcf object with a size", "catch_underarm",
       [](std::string t) {
         return set_value(t, "object", "{type: mjcf, file: body.xml, size: [0.1, 0.1, 0.1]}");
       },
       "object.size", "no 'size' for an mjcf object", "0.1"},
  };
  return cases;
}

}  // namespace

TEST_CASE("an unknown task id is a ConfigError listing the known ids", "[tasks][config]") {
  auto e = thrown<ConfigError>([] { tasks::make_task("nope"); });
  check_error(e, "", "task", "a known task id", "'nope'");
  for (const char* id : kTaskIds) CHECK(contains(e.expected(), id));
  auto e2 = thrown<ConfigError>([] { tasks::find_task("Catch_Underarm"); });
  CHECK(contains(e2.what(), "'Catch_Underarm'"));
  // every registered id resolves, to its own default YAML
  for (const char* id : kTaskIds) {
    CHECK(tasks::find_task(id).spec().id == id);
    auto t = tasks::make_task(id);
    CHECK(t->config_file() == tasks::default_task_config(id));
    CHECK(contains(t->config_file(), std::string("tasks/") + id + "/" + id + ".yaml"));
  }
  // and a slot count of zero
  auto e3 = thrown<ConfigError>([] { make_env("hand_over", 0); });
  CHECK(e3.key() == "nslot");
}

TEST_CASE("bad task YAML files are ConfigErrors naming the file and key and the expected and actual values",
          "[tasks][config]") {
  TaskTempDir dir;
  dir.write("body.xml", "<geom type=\"sphere\" size=\"0.03\" density=\"500\"/>\n");
  int n = 0;
  for (const auto& c : bad_yamls()) {
    INFO("case: " << c.what << " (" << c.task << ")");
    const std::string file = dir.write("bad" + std::to_string(n++) + ".yaml", c.edit(default_yaml(c.task)));
    auto e = thrown<ConfigError>([&] { tasks::make_task(c.task, file); });
    check_error(e, file, c.key, c.expected, c.actual);
  }
}

TEST_CASE("a YAML syntax error and a missing YAML file are named", "[tasks][config]") {
  TaskTempDir dir;
  const std::string file = dir.write("broken.yaml", "episode_length: [75\nobject: egg\n");
  auto e = thrown<ConfigError>([&] { tasks::make_task("catch_underarm", file); });
  CHECK(e.file().rfind(file, 0) == 0);
  CHECK(e.expected() == "valid YAML");
  CHECK(contains(e.actual(), "a syntax error"));
  auto io = thrown<IoError>([&] { tasks::make_task("catch_underarm", dir.file("absent.yaml")); });
  CHECK(contains(io.what(), dir.file("absent.yaml")));
}

TEST_CASE("an MJCF object with malformed XML is a ModelError naming the scene",
          "[tasks][config][objects]") {
  TaskTempDir dir;
  dir.write("broken.xml", "<geom type=\"box\" size=\"0.02 0.02 0.02\"\n");  // unclosed tag
  const std::string yaml = dir.write(
      "task.yaml", set_value(default_yaml("catch_underarm"), "object", "{type: mjcf, file: broken.xml}"));
  auto task = tasks::make_task("catch_underarm", yaml);  // the YAML itself is fine
  auto e = thrown<ModelError>([&] { make_env("catch_underarm", 1, 1, 0, yaml); });
  const std::string what = e.what();
  INFO("what(): " << what);
  CHECK(contains(what, "catch_underarm-v1 scene"));
  CHECK(contains(what, yaml));
}

TEST_CASE("a user MJCF body file builds and steps", "[tasks][config][objects]") {
  TaskTempDir dir;
  // a 4 cm box of density 400: 400 x 0.04^3 = 0.0256 kg
  dir.write("box.xml",
            "<geom name=\"user_box\" type=\"box\" size=\"0.02 0.02 0.02\" density=\"400\"/>\n"
            "<site name=\"user_site\" pos=\"0 0 0.02\"/>\n");
  const std::string yaml = dir.write(
      "task.yaml", set_value(default_yaml("catch_underarm"), "object", "{type: mjcf, file: box.xml, friction: 0.8}"));
  auto env = make_env("catch_underarm", 4, 3, 0, yaml);
  const mjModel* m = env->model().mj();
  const auto& o = object_of(*env, "object");
  CHECK(m->body_mass[o.body] == Approx(0.0256).epsilon(1e-9));
  const int g = mj_name2id(m, mjOBJ_GEOM, "user_box");
  REQUIRE(g >= 0);
  CHECK(m->geom_bodyid[g] == o.body);
  CHECK(mj_name2id(m, mjOBJ_SITE, "user_site") >= 0);
  // the goal marker of an mjcf object is a small sphere that touches nothing
  const auto& marker = object_of(*env, "goal");
  CHECK(marker.mocap >= 0);
  for (int k = 0; k < m->ngeom; ++k)
    if (m->geom_bodyid[k] == marker.body) {
      CHECK(m->geom_type[k] == mjGEOM_SPHERE);
      CHECK(m->geom_contype[k] == 0);
      CHECK(m->geom_conaffinity[k] == 0);
    }
  std::mt19937_64 rng(4);
  std::vector<float> a(static_cast<size_t>(env->nslot()) * env->act_dim());
  for (int i = 0; i < 100; ++i) {
    random_actions(a, rng);
    env->step(a);
    for (float x : env->obs) REQUIRE(std::isfinite(x));
  }
  CHECK(env->take_stats().faults == 0);
  CHECK(env->batch().total_faults() == 0);
}

// Each task's GPU room (constraint rows per world; a world that needs more is reset mid-episode)
// exceeds the most rows any committed GPU run of it needed: summary.json's gpu_rows under
// bench/results, trained policies included (re_orientation's 225 in MT20 at 191M slot-steps).
TEST_CASE("each task's GPU room exceeds the rows its runs have needed", "[tasks][config]") {
  const std::vector<std::pair<std::string, int>> most_rows = {
      {"hand_over", 104},         {"catch_underarm", 105},      {"catch_over2underarm", 111},
      {"catch_abreast", 111},     {"two_catch_underarm", 116},  {"lift_underarm", 182},
      {"door_open_outward", 194}, {"door_close_inward", 197},   {"door_open_inward", 167},
      {"door_close_outward", 172}, {"bottle_cap", 144},         {"push_block", 165},
      {"swing_cup", 148},         {"scissors", 171},            {"re_orientation", 225},
      {"pen", 154},               {"switch", 142},              {"block_stack", 202},
      {"pour_water", 326},        {"grasp_and_place", 286}};
  REQUIRE(most_rows.size() == tasks::task_registry().size());
  const sim::HandSpec hand = sim::load_hand_spec(sim::default_hand_path());
  const sim::PhysicsOptions gpu = sim::load_physics(sim::default_physics_path()).on_gpu();
  for (const auto& [id, rows] : most_rows) {
    INFO(id << " needed up to " << rows << " rows");
    CHECK(tasks::make_task(id)->scene(hand, gpu).physics().gpu.njmax > rows);
  }
}
