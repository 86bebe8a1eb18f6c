// tasks/objects: each preset object (egg, block, pen, ball) and a map-form object compile with
// the right shape and mass (density x volume, worked out by hand below) and step under random
// actions in catch_underarm without a fault.
#include <cmath>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

namespace {

struct ObjectCase {
  const char* yaml;  // the value of `object:`
  int geom_type;
  std::array<double, 3> size;
  double mass;       // kg
  double friction;
};

// Masses at 500 kg/m^3 (the original's density):
//   egg   ellipsoid 3 x 3 x 4 cm semi-axes: 500 x 4/3 pi 0.03 0.03 0.04     = 0.0753982 kg
//   block 5 cm cube:                        500 x 0.05^3                      = 0.0625 kg
//   pen   capsule r 8 mm, half length 0.1:  500 x (pi r^2 0.2 + 4/3 pi r^3)  = 0.0211785 kg
//   ball  r 3.5 cm:                         500 x 4/3 pi 0.035^3              = 0.0897972 kg
//   {type: ball, size: [0.05], density: 200, friction: 0.7}: 200 x 4/3 pi 0.05^3 = 0.1047198 kg
const std::vector<ObjectCase> kObjects = {
    {"egg", mjGEOM_ELLIPSOID, {0.03, 0.03, 0.04}, 0.0753982236861550, 1.0},
    {"block", mjGEOM_BOX, {0.025, 0.025, 0.025}, 0.0625, 1.0},
    {"pen", mjGEOM_CAPSULE, {0.008, 0.1, 0}, 0.0211785232754000, 1.0},
    {"ball", mjGEOM_SPHERE, {0.035, 0, 0}, 0.0897971900151083, 1.0},
    {"{type: ball, size: [0.05], density: 200, friction: 0.7}", mjGEOM_SPHERE, {0.05, 0, 0},
     0.104719755119660, 0.7},
};

}  // namespace

TEST_CASE("each object type builds with its mass and steps without faults",
          "[tasks][objects]") {
  TaskTempDir dir;
  int n = 0;
  for (const auto& c : kObjects) {
    INFO("object: " << c.yaml);
    const std::string yaml = dir.write("task" + std::to_string(n++) + ".yaml",
                                       set_value(default_yaml("catch_underarm"), "object", c.yaml));
    auto env = make_env("catch_underarm", 3, 31, 0, yaml);
    const mjModel* m = env->model().mj();
    const auto& o = object_of(*env, "object");
    CHECK(m->body_mass[o.body] == Approx(c.mass).epsilon(1e-6));
    int geoms = 0;
    for (int g = 0; g < m->ngeom; ++g) {
      if (m->geom_bodyid[g] != o.body) continue;
      ++geoms;
      CHECK(m->geom_type[g] == c.geom_type);
      const int used = c.geom_type == mjGEOM_SPHERE ? 1 : c.geom_type == mjGEOM_CAPSULE ? 2 : 3;
      for (int k = 0; k < used; ++k) CHECK(m->geom_size[3 * g + k] == Approx(c.size[k]));
      CHECK(m->geom_friction[3 * g] == Approx(c.friction));
    }
    CHECK(geoms == 1);
    // the goal marker has the object's shape, is a mocap body and touches nothing
    const auto& marker = object_of(*env, "goal");
    CHECK(marker.mocap >= 0);
    for (int g = 0; g < m->ngeom; ++g)
      if (m->geom_bodyid[g] == marker.body) {
        CHECK(m->geom_type[g] == c.geom_type);
        CHECK(m->geom_contype[g] == 0);
        CHECK(m->geom_conaffinity[g] == 0);
      }
    std::mt19937_64 rng(32);
    std::vector<float> a(static_cast<size_t>(env->nslot()) * env->act_dim());
    bool finite = true;
    for (int i = 0; i < 200; ++i) {
      random_actions(a, rng);
      env->step(a);
      for (float x : env->obs) finite = finite && std::isfinite(x);
      for (float x : env->reward) finite = finite && std::isfinite(x);
    }
    CHECK(finite);
    CHECK(env->take_stats().faults == 0);
    CHECK(env->batch().total_faults() == 0);
  }
}
