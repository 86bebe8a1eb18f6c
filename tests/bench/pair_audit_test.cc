// bench/pair_audit: the collision pairs each world tests, on the tasks' real scenes, against
// the contacts MuJoCo itself makes.
#include "bench/pair_audit.h"

#include <random>
#include <set>
#include <utility>
#include <vector>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "tasks/env.h"
#include "tasks/registry.h"

using namespace bidex;

TEST_CASE("the hands collide with each other only where the original let them",
          "[bench][pairs]") {
  // the catch tasks: the original's filter -1 parts the hands; bottle_cap: filter 0
  auto catch_task = tasks::make_task("catch_underarm");
  auto catch_model = tasks::build_task_model(*catch_task, "", "");
  const auto c = bench::audit_pairs(*catch_model);
  CHECK(c["by_kind"]["hand_hand"] == 0);
  CHECK(c["by_kind"]["hand_self"] == 28);   // 12 body pairs a hand, the palm's two boxes twice
  CHECK(c["by_kind"]["hand_object"] == 52); // the egg against every hand geom
  CHECK(c["explicit_pairs"] == 28);
  auto cap_task = tasks::make_task("bottle_cap");
  auto cap_model = tasks::build_task_model(*cap_task, "", "");
  const auto b = bench::audit_pairs(*cap_model);
  CHECK(b["by_kind"]["hand_hand"] == 26 * 26);
  CHECK(b["pairs_listed"].get<int>() < b["pairs_upper_triangle"].get<int>());
}

TEST_CASE("every contact MuJoCo makes is between a pair the audit lists", "[bench][pairs]") {
  for (const char* id : {"bottle_cap", "block_stack", "catch_abreast"}) {
    INFO(id);
    tasks::EnvOptions o;
    o.nslot = 16;
    o.threads = 1;
    o.seed = 3;
    tasks::TaskEnv env(tasks::make_task(id), o);
    const mjModel* m = env.model().mj();
    std::set<std::pair<int, int>> listed;
    for (const auto& p : bench::listed_pairs(m)) listed.insert({p.g1, p.g2});
    std::mt19937_64 rng(7);
    std::vector<float> actions(static_cast<size_t>(env.nslot()) * env.act_dim());
    int contacts = 0;
    for (int t = 0; t < 60; ++t) {
      tasks::random_actions(actions, rng);
      env.step(actions);
      for (int s = 0; s < env.nslot(); ++s) {
        const mjData* d = env.batch().data(s);
        for (int k = 0; k < d->ncon; ++k) {
          int g1 = d->contact[k].geom1, g2 = d->contact[k].geom2;
          if (g1 > g2) std::swap(g1, g2);
          ++contacts;
          CHECK(listed.count({g1, g2}) == 1);
        }
      }
    }
    CHECK(contacts > 0);
  }
}

TEST_CASE("the GPU's narrowphase path follows MuJoCo Warp's collision table", "[bench][pairs]") {
  CHECK_FALSE(bench::convex_path(mjGEOM_CAPSULE, mjGEOM_CAPSULE));
  CHECK_FALSE(bench::convex_path(mjGEOM_BOX, mjGEOM_CAPSULE));
  CHECK_FALSE(bench::convex_path(mjGEOM_SPHERE, mjGEOM_BOX));
  CHECK_FALSE(bench::convex_path(mjGEOM_PLANE, mjGEOM_ELLIPSOID));
  CHECK(bench::convex_path(mjGEOM_ELLIPSOID, mjGEOM_CAPSULE));
  CHECK(bench::convex_path(mjGEOM_CYLINDER, mjGEOM_CAPSULE));
  CHECK(bench::convex_path(mjGEOM_BOX, mjGEOM_BOX));
  CHECK_FALSE(bench::convex_path(mjGEOM_BOX, mjGEOM_BOX, /*native_box_box=*/true));
}
