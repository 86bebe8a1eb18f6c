// The GPU backend's plumbing on Warp's CPU device (no GPU needed): the embedded Python setup,
// the world-major arrays and their shapes, physics against the CPU batch, base forces, the fault
// check, resets and the overflow flag. The first construction on a machine compiles MuJoCo
// Warp's kernels for the CPU (Warp caches them under ~/.cache/warp).
#include "sim/warp_backend.h"

#include <cmath>
#include <limits>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "sim/batch.h"
#include "sim/cuda_driver.h"
#include "tasks/env.h"
#include "tasks/registry.h"
#include "tests/fixture.h"

namespace bidex::sim {
namespace {

WarpOptions cpu_options() {
  WarpOptions o;
  o.device = "cpu";
  return o;
}

// Largest |a - b| over a batch row and a backend row of the same width.
double max_diff(const std::vector<double>& a, const std::vector<float>& b, size_t offset,
                size_t n) {
  double m = 0;
  for (size_t i = 0; i < n; ++i) m = std::max(m, std::abs(a[offset + i] - double(b[offset + i])));
  return m;
}

// A task's scene as the GPU path compiles it.
std::unique_ptr<SimModel> task_scene(const char* id) {
  return tasks::build_task_model(*tasks::make_task(id, ""), "", "", /*on_gpu=*/true);
}

// Every world of `w` marked, reset and through the position pass.
void reset_all(WarpBackend& w) {
  const std::vector<int32_t> all(static_cast<size_t>(w.nworld()), 1);
  w.upload_bytes("reset", all.data(), all.size() * sizeof(int32_t));
  w.reset_begin();
  w.reset_end();
}

}  // namespace

TEST_CASE("WarpBackend exposes world-major arrays of the model's sizes", "[warp]") {
  const SimModel& model = test::two_hand_model();
  WarpBackend w(model, 3, cpu_options());
  CHECK_FALSE(w.on_gpu());
  CHECK(w.nworld() == 3);
  const mjModel* m = model.mj();
  const struct {
    const char* name;
    long width;
  } want[] = {{"qpos", m->nq},         {"qvel", m->nv},       {"ctrl", m->nu},
              {"sensordata", m->nsensordata}, {"xpos", 3 * m->nbody},
              {"xquat", 4 * m->nbody}, {"cvel", 6 * m->nbody}, {"subtree_com", 3 * m->nbody},
              {"mocap_pos", 3 * m->nmocap}, {"base_wrench", model.nwrench()},
              {"fault", 1}, {"fault_seen", 1}, {"reset", 1}};
  for (const auto& f : want) {
    INFO(f.name);
    const WorldArray a = w.array(f.name);
    CHECK(a.rows == 3);
    CHECK(a.width == static_cast<int>(f.width));
    if (a.width > 0) CHECK(a.ptr != 0);
  }
  CHECK_THROWS_WITH(w.array("qacc_bogus"), Catch::Contains("no array named 'qacc_bogus'"));
}

TEST_CASE("WarpBackend steps like the CPU batch from the same state and inputs", "[warp]") {
  const SimModel& model = test::two_hand_model();
  const mjModel* m = model.mj();
  SimBatch batch(model, 2, {1, 7});
  reset_all(model, batch);
  WarpBackend w(model, 2, cpu_options());

  // both start at the scene's initial state with targets at the joints
  auto qpos0 = w.download("qpos");
  CHECK(max_diff(batch.qpos, qpos0, 0, 2 * m->nq) < 1e-6);
  auto ctrl0 = w.download("ctrl");
  CHECK(max_diff(batch.ctrl, ctrl0, 0, 2 * m->nu) < 1e-6);

  // the same base push in world 1 on both sides: the base moves, world 0 keeps still
  std::vector<float> wrench(2 * model.nwrench(), 0.0f);
  wrench[model.nwrench() + 0] = 50.0f;  // right base, +x
  w.upload("base_wrench", wrench);
  for (int k = 0; k < model.nwrench(); ++k)
    batch.base_wrench[model.nwrench() + k] = wrench[model.nwrench() + k];
  for (int t = 0; t < 10; ++t) {
    step(model, batch);
    w.step();
  }
  const auto qpos = w.download("qpos");
  const auto xpos = w.download("xpos");
  // float32 against float64 after 80 physics steps with contacts (the egg in a hand): 7e-6 and
  // 4e-5 measured here
  CHECK(max_diff(batch.qpos, qpos, 0, 2 * m->nq) < 1e-4);
  CHECK(max_diff(batch.xpos, xpos, 0, 2 * 3 * m->nbody) < 4e-4);
  const int bx = model.hands()[0].base_qpos_adr;
  CHECK(batch.qpos[m->nq + bx] > 1e-3);                  // the pushed base moved along +x
  CHECK(std::abs(qpos[m->nq + bx] - batch.qpos[m->nq + bx]) < 1e-4);
  CHECK(std::abs(qpos[bx]) < 1e-5);                      // the other world's did not
  CHECK(w.total_faults() == 0);
  CHECK(w.room_advice().empty());
}

TEST_CASE("WarpBackend's substeps before the last skip the sensors and change nothing",
          "[warp]") {
  // the fingertip force and torque sensors read once per control step: computing them only in
  // the last substep leaves the state and the sensor values as every substep's computation does
  const SimModel& model = test::two_hand_model();
  const mjModel* m = model.mj();
  REQUIRE(m->nsensordata > 0);
  REQUIRE(model.physics().substeps > 1);
  WarpOptions every = cpu_options();
  every.sensors_every_substep = true;
  WarpBackend last(model, 2, cpu_options()), all(model, 2, every);
  SimBatch batch(model, 2, {1, 7});
  reset_all(model, batch);
  std::vector<float> wrench(2 * model.nwrench(), 0.0f);
  wrench[model.nwrench() + 0] = 50.0f;  // world 1: the right base pushed along +x
  for (auto* w : {&last, &all}) w->upload("base_wrench", wrench);
  for (int k = 0; k < model.nwrench(); ++k)
    batch.base_wrench[model.nwrench() + k] = wrench[model.nwrench() + k];
  for (int t = 0; t < 6; ++t) {
    last.step();
    all.step();
    step(model, batch);
  }
  for (const char* name : {"qpos", "qvel", "qfrc_constraint", "sensordata"}) {
    INFO(name);
    CHECK(last.download(name) == all.download(name));
  }
  // the values are this step's, not zeros or an earlier substep's: they match the CPU batch,
  // which computes them at every substep in float64 (4.6e-5 apart measured here, on values up
  // to 0.16)
  const auto sensors = last.download("sensordata");
  double largest = 0;
  for (float x : sensors) largest = std::max(largest, double(std::abs(x)));
  CHECK(largest > 0.05);
  CHECK(max_diff(batch.sensordata, sensors, 0, sensors.size()) < 1e-3);
}

TEST_CASE("WarpBackend flags a non-finite world, resets it alone and counts it", "[warp]") {
  const SimModel& model = test::two_hand_model();
  const mjModel* m = model.mj();
  WarpBackend w(model, 3, cpu_options());
  const auto qpos0 = w.download("qpos");
  w.step();
  auto qvel = w.download("qvel");
  qvel[1 * m->nv + 2] = std::numeric_limits<float>::quiet_NaN();
  w.upload("qvel", qvel);
  w.step();
  const auto fault = w.download_as<uint32_t>("fault");
  const auto reset = w.download_as<int32_t>("reset");
  CHECK(fault[0] == 0);
  CHECK((fault[1] & kFaultNonFinite) != 0);
  CHECK(fault[2] == 0);
  CHECK(reset == std::vector<int32_t>{0, 1, 0});
  const auto before = w.download("qpos");

  w.reset_begin();
  w.reset_end();
  const auto after = w.download("qpos");
  for (int i = 0; i < m->nq; ++i) {
    INFO("qpos " << i);
    CHECK(after[m->nq + i] == qpos0[m->nq + i]);   // world 1 is back at the initial state
    CHECK(after[i] == before[i]);                   // worlds 0 and 2 are untouched
    CHECK(after[2 * m->nq + i] == before[2 * m->nq + i]);
  }
  const auto xpos = w.download("xpos");
  for (float x : xpos) CHECK(std::isfinite(x));
  CHECK(w.total_faults() == 1);
  // the kinds each world has met are kept past its reset
  CHECK(w.fault_kinds() == std::map<std::string, int64_t>{{"non_finite", 1}});
  // the reset world steps on normally
  w.step();
  CHECK(w.download_as<uint32_t>("fault")[1] == 0);
  CHECK(w.download_as<uint32_t>("fault_seen") == std::vector<uint32_t>{0, kFaultNonFinite, 0});
}

TEST_CASE("WarpBackend flags worlds that run out of constraint rows", "[warp]") {
  const SimModel& model = test::two_hand_model();
  WarpOptions o = cpu_options();
  o.njmax = 4;  // the hands' joint limits and couplings need more rows than this
  WarpBackend w(model, 2, o);
  w.step();
  const auto fault = w.download_as<uint32_t>("fault");
  CHECK((fault[0] & kFaultOverflow) != 0);
  CHECK((fault[1] & kFaultOverflow) != 0);
  CHECK(w.total_overflows() == 2);
  CHECK(w.fault_kinds().at("overflow") == 2);
  // the rows the worlds needed are counted even past the room, and the advice names them
  const int need = w.max_rows();
  CHECK(need > 4);
  // and which kind of room ran out, and the one setting that widens it
  CHECK(w.download_as<uint32_t>("overflow_seen") ==
        std::vector<uint32_t>{kOverflowRows, kOverflowRows});
  CHECK_THAT(w.room_advice(), Catch::Contains("2 steps of worlds overflowed") &&
                                  Catch::Contains("(constraint rows; the room: 4 constraint rows") &&
                                  Catch::Contains("up to " + std::to_string(need) + " rows") &&
                                  Catch::EndsWith("raise gpu.njmax in the physics YAML "
                                                  "(configs/sim/physics.yaml, or the task's scene)"));
  // in the scene's own room the same step fits, and its use is counted the same way (the
  // states differ from the overflowed worlds', whose constraints were dropped)
  o.njmax = 0;
  WarpBackend roomy(model, 2, o);
  roomy.step();
  CHECK(roomy.total_overflows() == 0);
  CHECK(roomy.max_rows() > 4);
  CHECK(roomy.max_rows() <= roomy.options().njmax);
  CHECK(roomy.room_advice().empty());
}

TEST_CASE("WarpBackend names contacts as the room that ran out when they overflow", "[warp]") {
  // block_stack's blocks rest on the table from the first step: more contacts than one a world
  const auto scene = task_scene("block_stack");
  WarpOptions o = cpu_options();
  o.nconmax = 1;
  WarpBackend w(*scene, 2, o);
  w.step();
  CHECK(w.total_overflows() == 2);
  CHECK(w.download_as<uint32_t>("overflow_seen") ==
        std::vector<uint32_t>{kOverflowContacts, kOverflowContacts});
  CHECK_THAT(w.room_advice(), Catch::Contains("(contacts; the room: ") &&
                                  Catch::Contains(", 1 contacts per world;") &&
                                  Catch::Contains("raise gpu.nconmax in the physics YAML"));
  CHECK_THAT(w.room_advice(), !Catch::Contains("gpu.njmax"));
}

TEST_CASE("WarpBackend does not fault a world whose solver stops at its iteration cap",
          "[warp]") {
  // one Newton iteration: the hands' couplings and limits keep the solver from converging in
  // it, and MuJoCo Warp marks such a step in its overflow word; the step used the last iterate
  // (as MuJoCo's C library does on the CPU, silently), so it is no fault on either path
  sim::PhysicsOptions p = test::physics();
  p.iterations = 1;
  const SimModel model = two_hand_scene(test::shadow(), p).build("two_hand_scene, 1 iteration");
  WarpBackend w(model, 2, cpu_options());
  SimBatch cpu(model, 2, BatchOptions{1, 0});
  for (int i = 0; i < 4; ++i) {
    w.step();
    step(model, cpu);
  }
  CHECK(w.total_faults() == 0);
  CHECK(w.total_overflows() == 0);
  CHECK(w.room_advice().empty());
  CHECK(cpu.total_faults() == 0);
  for (float x : w.download("qpos")) CHECK(std::isfinite(x));
}

TEST_CASE("WarpBackend says what is missing when asked for a GPU it cannot have", "[warp]") {
  const SimModel& model = test::two_hand_model();
  WarpOptions o;
  o.device = "cuda";
  if (!cuda::driver_available()) {
    CHECK_THROWS_AS(WarpBackend(model, 2, o), DeviceError);
    CHECK_THROWS_WITH(WarpBackend(model, 2, o), Catch::Contains("no NVIDIA driver") &&
                                                    Catch::Contains("--device cpu"));
  }
  o.device = "cpu";
  CHECK_THROWS_WITH(WarpBackend(model, 0, o), Catch::Contains("nworld must be >= 1, got 0"));
}

TEST_CASE("WarpBackend steps scenes of one topology as each scene's own backend, bit for bit",
          "[warp]") {
  // MuJoCo Warp's float32 arithmetic depends on a backend's world count (one scene at 2 worlds
  // and at 3 differs in the last bits once contacts form), not on the packing: each scene's own
  // backend has as many worlds as the shared one, and world w of the shared backend is compared
  // with world w of its scene's own, under the same random inputs (keyed by world)
  const auto a = task_scene("catch_underarm"), b = task_scene("catch_abreast");
  WarpBackend shared({a.get(), b.get()}, {2, 2}, cpu_options());
  WarpBackend own_a(*a, 4, cpu_options()), own_b(*b, 4, cpu_options());
  REQUIRE(shared.nworld() == 4);
  CHECK(shared.scene_worlds() == std::vector<int>{2, 2});
  WarpBackend* all[] = {&shared, &own_a, &own_b};
  for (WarpBackend* w : all) reset_all(*w);
  auto rows = [](const WarpBackend& w, const char* name, int first, int count) {
    const WorldArray r = w.rows(name, first, count);
    std::vector<float> out(static_cast<size_t>(count) * r.width);
    w.download_bytes(name, out.data(), out.size() * sizeof(float), first);
    return out;
  };
  // each world starts from its own scene's state
  CHECK(rows(shared, "qpos", 0, 2) == rows(own_a, "qpos", 0, 2));
  CHECK(rows(shared, "qpos", 2, 2) == rows(own_b, "qpos", 2, 2));
  CHECK(rows(shared, "xpos", 2, 2) == rows(own_b, "xpos", 2, 2));
  CHECK(rows(shared, "xpos", 0, 1) != rows(shared, "xpos", 2, 1));  // the scenes differ
  for (int t = 0; t < 30; ++t)
    for (WarpBackend* w : all) {
      w->random_inputs(7, t, 20, 2);
      w->step();
    }
  for (const char* name : {"qpos", "qvel", "sensordata", "xpos"}) {
    INFO(name);
    CHECK(rows(shared, name, 0, 2) == rows(own_a, name, 0, 2));
    CHECK(rows(shared, name, 2, 2) == rows(own_b, name, 2, 2));
  }
  CHECK(shared.total_faults() == 0);
  CHECK_THROWS_WITH(shared.rows("qpos", 3, 2), Catch::Contains("rows 3 to 5 of 'qpos', which has 4"));
}

TEST_CASE("scenes of different topologies are refused a shared backend, naming the field",
          "[warp]") {
  const auto a = task_scene("catch_underarm"), b = task_scene("catch_abreast"),
             c = task_scene("push_block");
  CHECK(WarpBackend::topology_groups({a.get(), c.get(), b.get()}) == std::vector<int>{0, 1, 0});
  try {
    WarpBackend w({a.get(), c.get()}, {1, 1}, cpu_options());
    FAIL("two topologies on one backend");
  } catch (const DeviceError& e) {
    CHECK_THAT(e.what(), Catch::Contains("2 scenes") && Catch::Contains("scenes 0 and 1 differ") &&
                             Catch::Contains("cannot take per world"));
  }
  CHECK_THROWS_WITH(WarpBackend({a.get(), b.get()}, {1}, cpu_options()),
                    Catch::Contains("2 scenes and 1 world counts"));
  CHECK_THROWS_WITH(WarpBackend({a.get(), b.get()}, {1, 0}, cpu_options()),
                    Catch::Contains("nworld must be >= 1, got 0 for scene 1"));
  std::vector<float> too_many(100, 0.f);
  WarpBackend w(*a, 2, cpu_options());
  CHECK_THROWS_WITH(w.upload_bytes("ctrl", too_many.data(), too_many.size() * sizeof(float), 1),
                    Catch::Contains("passes its end"));
}

}  // namespace bidex::sim
