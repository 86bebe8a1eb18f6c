// sim/gpu/model: the engine's tables for the two-hand scene, and the clear refusals of models
// with features part 1 of the engine does not implement.
#include "sim/gpu/model.h"

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "core/error.h"
#include "sim/gpu/parity.h"
#include "sim/model.h"
#include "tests/fixture.h"

using namespace bidex;
using namespace bidex::sim::gpu;

namespace {

// ModelError message of building the tables for `xml` (fails the test if there is none)
std::string refusal(const std::string& xml, EngineOptions options = {}) {
  mjModel* m = sim::compile_mjcf(xml, "gpu_model_test");
  std::string what;
  try {
    ModelArrays a(m, options);
  } catch (const ModelError& e) {
    what = e.what();
  }
  mj_deleteModel(m);
  INFO("model: " << xml);
  REQUIRE(!what.empty());
  return what;
}

const char* kChain =
    "<mujoco><compiler angle='radian'/><option><flag contact='disable'/></option><worldbody>"
    "<body name='p'><joint name='a' type='hinge'/><geom size='0.1' mass='1'/>"
    "  <body pos='0 0 0.3'><joint name='b' type='hinge'/><geom size='0.1' mass='1'/></body>"
    "</body>"
    "<body name='r' pos='1 0 0'><joint name='c' type='hinge'/><geom size='0.1' mass='1'/></body>"
    "</worldbody>";

std::string chain_with(const std::string& extra) {
  std::string s(kChain);
  s.append(extra);
  s.append("</mujoco>");
  return s;
}

}  // namespace

TEST_CASE("the two-hand scene's tables: a candidate row per coupling, friction dof, limit side",
          "[sim][gpu]") {
  const mjModel* full = bidex::test::two_hand_model().mj();
  mjModel* m = contact_free_copy(full);
  ModelArrays a(m);
  CHECK(a.s.nv == m->nv);
  CHECK(a.s.nM == m->nM);
  int nfric = 0, nlim = 0;
  for (int i = 0; i < m->nv; ++i) nfric += m->dof_frictionloss[i] > 0;
  for (int j = 0; j < m->njnt; ++j) nlim += m->jnt_limited[j] ? 2 : 0;
  CHECK(a.s.ncand == m->neq + nfric + nlim);
  // the couplings are the first rows, in equality order
  for (int i = 0; i < m->neq; ++i) {
    CHECK(a.cand_kind[i] == kCandEqJoint);
    CHECK(a.cand_id[i] == i);
  }
  // every level lists bodies whose parents sit one level up
  for (int l = 1; l < a.s.nlevel; ++l)
    for (int k = a.level_adr[l]; k < a.level_adr[l + 1]; ++k) {
      const int p = m->body_parentid[a.level_body[k]];
      CHECK(p >= 0);
      bool above = false;
      for (int q = a.level_adr[l - 1]; q < a.level_adr[l]; ++q) above |= a.level_body[q] == p;
      CHECK(above);
    }
  mj_deleteModel(m);
}

TEST_CASE("models the engine cannot simulate yet are refused with the reason", "[sim][gpu]") {
  // contacts: the scene as built collides; part 1 needs them disabled or explicitly ignored
  mjModel* scene = mj_copyModel(nullptr, bidex::test::two_hand_model().mj());
  try {
    ModelArrays a(scene);
    FAIL("a model with contacts was accepted");
  } catch (const ModelError& e) {
    CHECK(std::string(e.what()).find("contacts") != std::string::npos);
  }
  CHECK_NOTHROW(ModelArrays(scene, EngineOptions{/*ignore_contacts=*/true}));
  mj_deleteModel(scene);

  CHECK(refusal(chain_with("<option integrator='RK4'/>")).find("Euler") != std::string::npos);
  CHECK(refusal(chain_with("<equality><connect body1='p' body2='r' anchor='0 0 0'/>"
                           "</equality>"))
            .find("joint and tendon equalities") != std::string::npos);
  CHECK(refusal(chain_with("<equality><joint joint1='b' joint2='c'/></equality>"))
            .find("kinematic chain") != std::string::npos);
  CHECK(refusal(chain_with("<actuator><general joint='a' dyntype='filter'/></actuator>"))
            .find("activation") != std::string::npos);
}
