// apps/cmd_model: `bidex model` writes standalone MJCF that MuJoCo loads from disk and that
// MuJoCo's own Python package (the wheel in .venv/ that bidex builds against) compiles.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "core/files.h"
#include "tasks/env.h"
#include "tasks/registry.h"
#include "tests/fixture.h"
#include "tests/paper_table.h"
#include "tests/run_command.h"

using bidex::test::TempDir;

namespace {

using bidex::test::CommandResult;
using bidex::test::run_command;


std::string quote(const std::string& s) { return "'" + s + "'"; }

std::string bidex_cmd(const std::string& args) { return quote(BIDEX_BINARY) + " " + args; }

struct LoadedModel {
  mjModel* m = nullptr;
  std::string error;
  LoadedModel(const std::string& path, bool binary) {
    char err[1024] = "";
    m = binary ? mj_loadModel(path.c_str(), nullptr) : mj_loadXML(path.c_str(), nullptr, err, sizeof err);
    error = err;
  }
  ~LoadedModel() {
    if (m) mj_deleteModel(m);
  }
};

// The hands of the file have the paper's joints, ranges and force limits.
void check_paper_hand(const mjModel* m, const std::string& prefix) {
  for (auto& j : bidex::test::kPaperJoints) {
    INFO(prefix << j.name);
    int jid = mj_name2id(m, mjOBJ_JOINT, (prefix + j.name).c_str());
    REQUIRE(jid >= 0);
    CHECK(m->jnt_range[2 * jid] == Approx(j.min_deg * bidex::test::kDeg).margin(1e-9));
    CHECK(m->jnt_range[2 * jid + 1] == Approx(j.max_deg * bidex::test::kDeg).margin(1e-9));
    int aid = mj_name2id(m, mjOBJ_ACTUATOR, (prefix + j.name).c_str());
    CHECK((aid >= 0) == j.actuated);
    if (aid >= 0) CHECK(m->actuator_forcerange[2 * aid + 1] == Approx(j.force_limit));
  }
}

}  // namespace

TEST_CASE("bidex model --hand both writes MJCF that MuJoCo loads from disk", "[apps][model]") {
  TempDir dir;
  std::string xml = dir.file("hands.xml");
  CommandResult r = run_command(bidex_cmd("model --hand both --out " + quote(xml)));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK(r.out.find("wrote " + xml) != std::string::npos);
  REQUIRE(std::filesystem::exists(xml));
  CHECK(dir.list() == std::vector<std::string>{"hands.xml"});  // no temp file left

  LoadedModel disk(xml, false);
  INFO("mj_loadXML: " << disk.error);
  REQUIRE(disk.m != nullptr);
  const size_t nbody_hand = bidex::test::shadow().bodies.size();
  CHECK(disk.m->nbody == static_cast<int>(1 + 2 * nbody_hand));
  CHECK(disk.m->njnt == 48);
  CHECK(disk.m->nu == 40);
  CHECK(disk.m->neq == 8);
  CHECK(disk.m->nsensor == 20);
  check_paper_hand(disk.m, "rh_");
  check_paper_hand(disk.m, "lh_");
  // the same model as the scene builder's, compiled in memory
  const mjModel* mem = bidex::test::fixed_hands_model().mj();
  REQUIRE(disk.m->nq == mem->nq);
  CHECK(bidex::test::same_bits(disk.m->jnt_range, mem->jnt_range, 2 * mem->njnt));
  CHECK(bidex::test::same_bits(disk.m->body_mass, mem->body_mass, mem->nbody));
  CHECK(bidex::test::same_bits(disk.m->qpos0, mem->qpos0, mem->nq));

  // MuJoCo's Python package compiles the file and saves the binary model, which loads here
  const std::string python = std::string(BIDEX_SOURCE_DIR) + "/.venv/bin/python";
  if (!std::filesystem::exists(python)) {
    WARN(python << " is missing (scripts/setup.sh makes it): skipping the check with MuJoCo's "
                   "Python package");
    return;
  }
  std::string mjb = dir.file("hands.mjb");
  CommandResult c = run_command(quote(python) +
                                " -c 'import mujoco, sys; mujoco.mj_saveModel("
                                "mujoco.MjModel.from_xml_path(sys.argv[1]), sys.argv[2], None)' " +
                                quote(xml) + " " + quote(mjb) + " 2>&1");
  INFO("mujoco (Python): " << c.out);
  CHECK(c.rc == 0);
  REQUIRE(std::filesystem::exists(mjb));
  LoadedModel bin(mjb, true);
  REQUIRE(bin.m != nullptr);
  CHECK(bin.m->nq == disk.m->nq);
  CHECK(bin.m->nu == disk.m->nu);
  CHECK(bin.m->nbody == disk.m->nbody);
  CHECK(bidex::test::same_bits(bin.m->actuator_forcerange, disk.m->actuator_forcerange,
                               2 * disk.m->nu));
}

TEST_CASE("bidex model writes one hand, fixed or free", "[apps][model]") {
  TempDir dir;
  struct Case {
    const char* hand;
    const char* base;
    const char* prefix;
    int njnt;
  };
  for (Case c : {Case{"right", "fixed", "rh_", 24}, Case{"left", "free", "lh_", 28},
                 Case{"right", "free", "rh_", 28}}) {
    INFO(c.hand << " " << c.base);
    std::string xml = dir.file(std::string(c.hand) + "_" + c.base + ".xml");
    CommandResult r = run_command(bidex_cmd(std::string("model --hand ") + c.hand + " --base " + c.base +
                             " --out " + quote(xml)));
    INFO(r.out);
    REQUIRE(r.rc == 0);
    LoadedModel disk(xml, false);
    INFO(disk.error);
    REQUIRE(disk.m != nullptr);
    CHECK(disk.m->njnt == c.njnt);
    CHECK(disk.m->nu == 20);
    check_paper_hand(disk.m, c.prefix);
    std::string other = std::string(c.prefix) == "rh_" ? "lh_FF3" : "rh_FF3";
    CHECK(mj_name2id(disk.m, mjOBJ_JOINT, other.c_str()) == -1);
  }
}

TEST_CASE("bidex model reports bad input with the file, key and reason", "[apps][model]") {
  TempDir dir;
  SECTION("a bad hand spec: exit code 2, the error names file and key") {
    std::string spec = dir.file("hand.yaml");
    std::string text = bidex::read_file(bidex::sim::default_hand_path());
    text = bidex::test::replace_once(text, "range_deg: [-20, 20], actuator: {force_limit: 0.725}}\n"
                                           "    geoms:\n      - {name: ffknuckle",
                                     "range_deg: [20, -20], actuator: {force_limit: 0.725}}\n"
                                     "    geoms:\n      - {name: ffknuckle");
    bidex::write_file_atomic(spec, text);
    std::string xml = dir.file("out.xml");
    CommandResult r = run_command(bidex_cmd("model --spec " + quote(spec) + " --out " + quote(xml)));
    INFO(r.out);
    CHECK(r.rc == 2);
    CHECK(r.out.find(spec) != std::string::npos);
    CHECK(r.out.find("bodies[3].joint.range_deg") != std::string::npos);
    CHECK(r.out.find("[20, -20]") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(xml));
  }
  SECTION("an output path below a regular file: exit code 2, the error names it") {
    std::string blocker = dir.file("file");
    bidex::write_file_atomic(blocker, "x");
    std::string xml = blocker + "/sub/out.xml";
    CommandResult r = run_command(bidex_cmd("model --out " + quote(xml)));
    INFO(r.out);
    CHECK(r.rc == 2);
    CHECK(r.out.find(xml) != std::string::npos);
  }
  SECTION("an unknown hand name is refused by the command line") {
    CommandResult r = run_command(bidex_cmd("model --hand middle --out " + quote(dir.file("x.xml"))));
    INFO(r.out);
    CHECK(r.rc != 0);
    CHECK(r.out.find("middle") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(dir.file("x.xml")));
  }
}

TEST_CASE("bidex model --task writes the task's whole scene as its environment compiles it",
          "[apps][model]") {
  TempDir dir;
  for (const char* id : {"door_open_inward", "pour_water"}) {
    INFO(id);
    const std::string xml = dir.file(std::string(id) + ".xml");
    CommandResult r = run_command(bidex_cmd(std::string("model --task ") + id + " --out " + quote(xml)));
    INFO(r.out);
    REQUIRE(r.rc == 0);
    CHECK(r.out.find(std::string("the scene of ") + id) != std::string::npos);
    LoadedModel disk(xml, false);
    INFO("mj_loadXML: " << disk.error);
    REQUIRE(disk.m != nullptr);
    // the same scene as the task's environment builds in memory: objects, tables, goal markers
    std::unique_ptr<bidex::tasks::Task> task = bidex::tasks::make_task(id);
    std::unique_ptr<bidex::sim::SimModel> mem = bidex::tasks::build_task_model(*task, "", "");
    const mjModel* m = mem->mj();
    REQUIRE(disk.m->nbody == m->nbody);
    REQUIRE(disk.m->ngeom == m->ngeom);
    CHECK(disk.m->nq == m->nq);
    CHECK(disk.m->nu == m->nu);
    CHECK(disk.m->nmocap == m->nmocap);
    CHECK(bidex::test::same_bits(disk.m->body_pos, m->body_pos, 3 * m->nbody));
    CHECK(bidex::test::same_bits(disk.m->geom_size, m->geom_size, 3 * m->ngeom));
    CHECK(bidex::test::same_bits(disk.m->qpos0, m->qpos0, m->nq));
    CHECK(disk.m->nbody > bidex::test::fixed_hands_model().mj()->nbody);  // more than the hands
  }
}

TEST_CASE("bidex model --task refuses an unknown task and the hand-only options", "[apps][model]") {
  TempDir dir;
  const std::string xml = dir.file("x.xml");
  CommandResult r = run_command(bidex_cmd("model --task pour_tea --out " + quote(xml)));
  INFO(r.out);
  CHECK(r.rc == 2);
  CHECK(r.out.find("pour_tea") != std::string::npos);
  CHECK(r.out.find("pour_water") != std::string::npos);  // the known ids are listed
  CHECK_FALSE(std::filesystem::exists(xml));
  r = run_command(bidex_cmd("model --task pen --hand left --out " + quote(xml)));
  INFO(r.out);
  CHECK(r.rc != 0);
  CHECK(r.out.find("--hand excludes --task") != std::string::npos);
  r = run_command(bidex_cmd("model --gpu --out " + quote(xml)));
  INFO(r.out);
  CHECK(r.rc != 0);
  CHECK(r.out.find("--gpu requires --task") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(xml));
}
