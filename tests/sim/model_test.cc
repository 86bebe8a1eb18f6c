// sim/model: compiling MJCF from memory, the SimModel index tables, moves and the gravity
// compensation table.
#include "sim/model.h"

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "sim/scene.h"
#include "tests/fixture.h"

using namespace bidex;
using namespace bidex::sim;
using bidex::test::physics;
using bidex::test::shadow;

TEST_CASE("compile_mjcf compiles from memory and reports MuJoCo's errors", "[sim][model]") {
  mjModel* m = compile_mjcf(
      "<mujoco><worldbody><body><joint type=\"hinge\"/><geom size=\"0.1\"/></body></worldbody>"
      "</mujoco>",
      "tiny");
  REQUIRE(m != nullptr);
  CHECK(m->njnt == 1);
  CHECK(m->nbody == 2);
  mj_deleteModel(m);

  try {
    compile_mjcf("<mujoco><worldbody><geom type=\"box\" size=\"1 1\" fromto=\"0 0\"/>"
                 "</worldbody></mujoco>",
                 "broken_box");
    FAIL("no error");
  } catch (const ModelError& e) {
    std::string what = e.what();
    INFO(what);
    CHECK(what.rfind("broken_box: ", 0) == 0);
    CHECK(what.find("MuJoCo") != std::string::npos);
    CHECK(what.size() > std::string("broken_box: MuJoCo could not compile the model: ").size());
  }
}

TEST_CASE("the index tables point at the right MuJoCo objects", "[sim][model]") {
  const SimModel& model = bidex::test::two_hand_model();
  const mjModel* m = model.mj();
  for (const HandIndex& h : model.hands()) {
    INFO(h.prefix);
    for (size_t i = 0; i < h.joints.size(); ++i) {
      CHECK(std::string(mj_id2name(m, mjOBJ_JOINT, h.joints[i])) == h.prefix + h.joint_names[i]);
      CHECK(h.dof_adr[i] == m->jnt_dofadr[h.joints[i]]);
    }
    for (size_t k = 0; k < h.actuators.size(); ++k)
      CHECK(m->actuator_trnid[2 * h.actuators[k]] == h.joints[h.actuated[k]]);
    const char* tips[5] = {"fftip", "mftip", "rftip", "lftip", "thtip"};
    REQUIRE(h.tip_sites.size() == 5);
    for (size_t t = 0; t < 5; ++t) {
      CHECK(std::string(mj_id2name(m, mjOBJ_SITE, h.tip_sites[t])) == h.prefix + tips[t]);
      CHECK(h.tip_bodies[t] == m->site_bodyid[h.tip_sites[t]]);
      // the force and torque sensors of this tip, 3 values each
      int fs = -1, ts = -1;
      for (int s = 0; s < m->nsensor; ++s) {
        if (m->sensor_adr[s] == h.tip_force_adr[t]) fs = s;
        if (m->sensor_adr[s] == h.tip_torque_adr[t]) ts = s;
      }
      REQUIRE(fs >= 0);
      REQUIRE(ts >= 0);
      CHECK(m->sensor_type[fs] == mjSENS_FORCE);
      CHECK(m->sensor_type[ts] == mjSENS_TORQUE);
      CHECK(m->sensor_objid[fs] == h.tip_sites[t]);
      CHECK(m->sensor_objid[ts] == h.tip_sites[t]);
      CHECK(m->sensor_dim[fs] == 3);
    }
    // the base: 3 slides then a ball, 7 qpos and 6 dofs, consecutive
    int jx = mj_name2id(m, mjOBJ_JOINT, (h.prefix + "base_x").c_str());
    int jr = mj_name2id(m, mjOBJ_JOINT, (h.prefix + "base_rot").c_str());
    CHECK(h.base_qpos_adr == m->jnt_qposadr[jx]);
    CHECK(m->jnt_qposadr[jr] == h.base_qpos_adr + 3);
    CHECK(m->jnt_dofadr[jr] == h.base_dof_adr + 3);
    CHECK(m->jnt_bodyid[jx] == h.root_body);
  }
  const ObjectIndex* egg = model.object("object");
  REQUIRE(egg != nullptr);
  int j = mj_name2id(m, mjOBJ_JOINT, "object");
  CHECK(m->jnt_type[j] == mjJNT_FREE);
  CHECK(egg->qpos_adr == m->jnt_qposadr[j]);
  CHECK(egg->dof_adr == m->jnt_dofadr[j]);
}

TEST_CASE("SimModel moves, and gravity compensation follows the physics option", "[sim][model]") {
  PhysicsOptions p = physics();
  p.gravity_free_hands = false;
  SceneBuilder sb(p);
  sb.add_hand(shadow(), {Side::kRight, Pose{}, Base::kFixed});
  SimModel a = sb.build("heavy");
  for (int b = 0; b < a.mj()->nbody; ++b) CHECK(a.mj()->body_gravcomp[b] == 0.0);

  const mjModel* raw = a.mj();
  SimModel b(std::move(a));
  CHECK(b.mj() == raw);
  CHECK(a.mj() == nullptr);  // NOLINT(bugprone-use-after-move): moved-from is empty
  CHECK(b.hands().size() == 1);
  CHECK(b.nu() == 20);

  SimModel c = SceneBuilder(physics()).build("empty");
  CHECK(c.hands().empty());
  CHECK(c.nwrench() == 0);
  c = std::move(b);
  CHECK(c.mj() == raw);
  CHECK(c.physics().gravity_free_hands == false);
  CHECK(c.mjcf().find("rh_FF3") != std::string::npos);
}
