// sim/batch: bitwise determinism over thread counts, fault isolation (NaN inputs, exploding
// state), resets and per-slot random streams, and a small soak under random inputs.
#include "sim/batch.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>
#include <omp.h>

#include "sim/scene.h"
#include "tests/fixture.h"

using namespace bidex;
using namespace bidex::sim;
using bidex::test::same_bits;
using bidex::test::two_hand_model;

namespace {

// catch_underarm's limits on the random base wrench
constexpr double kForce = 83.3, kTorque = 8.33;

// Every per-slot array of a batch, for bitwise comparisons of one slot between batches.
struct SlotRows {
  std::vector<std::pair<const char*, std::vector<double>>> rows;
  double time = 0;
};

SlotRows rows_of(SimBatch& b, int s) {
  SlotRows out;
  SlotView v = b.slot(s);
#define BIDEX_X(name, width, doc) \
  out.rows.push_back({#name, std::vector<double>(v.name, v.name + b.name##_width)});
  BIDEX_BATCH_INPUTS(BIDEX_X)
  BIDEX_BATCH_OUTPUTS(BIDEX_X)
#undef BIDEX_X
  out.time = b.time[s];
  return out;
}

// Bitwise comparison of two slots' rows (all fields), naming the first field that differs.
void check_same_rows(const SlotRows& a, const SlotRows& b, const std::string& what) {
  INFO(what);
  REQUIRE(a.rows.size() == b.rows.size());
  for (size_t i = 0; i < a.rows.size(); ++i) {
    INFO("field " << a.rows[i].first);
    REQUIRE(a.rows[i].second.size() == b.rows[i].second.size());
    CHECK(same_bits(a.rows[i].second.data(), b.rows[i].second.data(), a.rows[i].second.size()));
  }
  CHECK(a.time == b.time);
}

// The MuJoCo state of a slot that the next step depends on (beyond the output rows).
void check_same_mjdata(const mjModel* m, const mjData* a, const mjData* b) {
  CHECK(same_bits(a->qpos, b->qpos, m->nq));
  CHECK(same_bits(a->qvel, b->qvel, m->nv));
  CHECK(same_bits(a->qacc, b->qacc, m->nv));
  CHECK(same_bits(a->qacc_warmstart, b->qacc_warmstart, m->nv));
  CHECK(same_bits(a->ctrl, b->ctrl, m->nu));
  CHECK(same_bits(a->xfrc_applied, b->xfrc_applied, 6 * m->nbody));
  CHECK(same_bits(a->sensordata, b->sensordata, m->nsensordata));
  CHECK(a->time == b->time);
}

// Runs `steps` control steps of random inputs; returns the trajectory of qpos, qvel, sensordata.
std::vector<double> trajectory(int nslot, int threads, uint64_t seed, int steps) {
  const SimModel& model = two_hand_model();
  SimBatch batch(model, nslot, {threads, seed});
  REQUIRE(batch.threads() == threads);
  std::vector<double> out;
  for (int k = 0; k < steps; ++k) {
    random_inputs(model, batch, kForce, kTorque);
    step(model, batch);
    out.insert(out.end(), batch.qpos.begin(), batch.qpos.end());
    out.insert(out.end(), batch.qvel.begin(), batch.qvel.end());
    out.insert(out.end(), batch.sensordata.begin(), batch.sensordata.end());
  }
  REQUIRE(batch.total_faults() == 0);
  return out;
}

int64_t mujoco_log_size() {
  std::error_code ec;
  auto n = std::filesystem::file_size("MUJOCO_LOG.TXT", ec);
  return ec ? -1 : static_cast<int64_t>(n);
}

}  // namespace

TEST_CASE("a batch starts every slot from the initial state", "[sim][batch]") {
  const SimModel& model = two_hand_model();
  SimBatch batch(model, 3, {1, 5});
  CHECK(batch.nslot() == 3);
  CHECK(batch.ctrl_width == model.nu());
  CHECK(batch.base_wrench_width == 12);
  CHECK(batch.qpos_width == model.nq());
  CHECK(batch.qpos.size() == 3u * model.nq());
  CHECK(batch.xquat_width == 4 * model.nbody());
  CHECK(batch.bytes() > 3 * model.data_bytes());
  for (int s = 0; s < 3; ++s) {
    CHECK(batch.episode[s] == 0);
    CHECK(batch.fault[s] == kFaultNone);
    CHECK(batch.fault_count[s] == 0);
    CHECK(batch.time[s] == 0);
    // rows equal the slot's mjData
    CHECK(same_bits(batch.slot(s).qpos, batch.data(s)->qpos, model.nq()));
    CHECK(same_bits(batch.slot(s).xpos, batch.data(s)->xpos, 3 * model.nbody()));
  }
  check_same_rows(rows_of(batch, 0), rows_of(batch, 2), "slot 0 vs slot 2");
  // targets start at the (clamped) joint angles: a zero-input step leaves the hands still
  const auto& h = *model.hand(Side::kRight);
  for (size_t k = 0; k < h.actuators.size(); ++k)
    CHECK(batch.ctrl[h.actuators[k]] == batch.qpos[h.qpos_adr[h.actuated[k]]]);

  CHECK_THROWS_AS(SimBatch(model, 0), ConfigError);
  SimBatch all(model, 1, {0, 0});
  CHECK(all.threads() == omp_get_max_threads());
  all.set_threads(3);
  CHECK(all.threads() == 3);
}

TEST_CASE("stepping is bitwise identical for any thread count", "[sim][batch][determinism]") {
  const int nslot = 16, steps = 30;
  const uint64_t seed = 42;
  std::vector<double> ref = trajectory(nslot, 1, seed, steps);
  REQUIRE_FALSE(ref.empty());
  for (int threads : {2, omp_get_max_threads(), 5}) {
    INFO(threads << " threads");
    std::vector<double> run = trajectory(nslot, threads, seed, steps);
    REQUIRE(run.size() == ref.size());
    CHECK(same_bits(run.data(), ref.data(), ref.size()));
  }
  // the slots are not all alike (each has its own stream), and another seed changes the run
  const SimModel& model = two_hand_model();
  size_t per_step = static_cast<size_t>(nslot) * (model.nq() + model.nv() + model.nsensordata());
  const double* last_qpos = ref.data() + (steps - 1) * per_step;
  CHECK_FALSE(same_bits(last_qpos, last_qpos + model.nq(), model.nq()));
  std::vector<double> other = trajectory(nslot, 2, seed + 1, steps);
  REQUIRE(other.size() == ref.size());
  CHECK_FALSE(same_bits(other.data(), ref.data(), ref.size()));
  // and the same seed twice on the same thread count is the same run
  CHECK(same_bits(trajectory(nslot, 2, seed, steps).data(), ref.data(), ref.size()));
}

TEST_CASE("a non-finite input faults and resets only its own slot", "[sim][batch][faults]") {
  const SimModel& model = two_hand_model();
  const int nslot = 6, bad = 3, before = 5, after = 5;

  // what to poison: a ctrl entry, or a base wrench entry (either hand)
  struct Poison {
    const char* name;
    bool wrench;
    int index;
    double value;
  };
  auto which = GENERATE(Poison{"ctrl[7] = NaN", false, 7, std::numeric_limits<double>::quiet_NaN()},
                        Poison{"ctrl[39] = +inf", false, 39, std::numeric_limits<double>::infinity()},
                        Poison{"base_wrench[2] = NaN", true, 2, std::numeric_limits<double>::quiet_NaN()},
                        Poison{"base_wrench[10] = -inf", true, 10, -std::numeric_limits<double>::infinity()});
  INFO(which.name);

  SimBatch clean(model, nslot, {2, 11});
  SimBatch dirty(model, nslot, {2, 11});
  SimBatch fresh(model, nslot, {1, 11});  // the reference of a reset slot
  for (int k = 0; k < before; ++k) {
    random_inputs(model, clean, kForce, kTorque);
    random_inputs(model, dirty, kForce, kTorque);
    step(model, clean);
    step(model, dirty);
  }
  REQUIRE(dirty.total_faults() == 0);
  random_inputs(model, clean, kForce, kTorque);
  random_inputs(model, dirty, kForce, kTorque);
  auto row = dirty.slot(bad);
  (which.wrench ? row.base_wrench : row.ctrl)[which.index] = which.value;

  int64_t log_before = mujoco_log_size();
  bidex::test::CaptureOutput capture;
  step(model, clean);
  step(model, dirty);
  std::string printed = capture.text();
  CHECK(printed.empty());
  CHECK(mujoco_log_size() == log_before);

  // exactly the poisoned slot is flagged, counted and reset
  for (int s = 0; s < nslot; ++s) {
    INFO("slot " << s);
    CHECK(dirty.fault[s] == (s == bad ? kFaultBadInput : kFaultNone));
    CHECK(dirty.fault_count[s] == (s == bad ? 1 : 0));
    CHECK(dirty.episode[s] == (s == bad ? 1 : 0));
    CHECK(clean.fault[s] == kFaultNone);
  }
  CHECK(dirty.total_faults() == 1);
  // the reset slot is the fresh initial state, rows and MuJoCo data (the fresh slot has the
  // same index, so its rows are a reset of the same slot)
  check_same_rows(rows_of(dirty, bad), rows_of(fresh, bad), "faulted slot vs a fresh slot");
  check_same_mjdata(model.mj(), dirty.data(bad), fresh.data(bad));
  CHECK(dirty.time[bad] == 0);
  // every other slot is bitwise the run without the poison, now and after more steps
  for (int k = 0; k <= after; ++k) {
    for (int s = 0; s < nslot; ++s)
      if (s != bad) check_same_rows(rows_of(dirty, s), rows_of(clean, s), "slot " + std::to_string(s));
    random_inputs(model, clean, kForce, kTorque);
    random_inputs(model, dirty, kForce, kTorque);
    step(model, clean);
    step(model, dirty);
  }
  CHECK(dirty.total_faults() == 1);
  CHECK(dirty.fault[bad] == kFaultNone);  // the flag is per step
}

TEST_CASE("an exploding state faults and resets only its own slot", "[sim][batch][faults]") {
  const SimModel& model = two_hand_model();
  const int nslot = 4, bad = 1;
  SimBatch clean(model, nslot, {2, 5});
  SimBatch dirty(model, nslot, {2, 5});
  SimBatch fresh(model, nslot, {1, 5});
  for (int k = 0; k < 3; ++k) {
    random_inputs(model, clean, kForce, kTorque);
    random_inputs(model, dirty, kForce, kTorque);
    step(model, clean);
    step(model, dirty);
  }
  // task code writes a huge velocity into the slot's MuJoCo data: 1e9 rad/s on a finger joint
  // (MuJoCo itself gives up on this one), or the egg flying up at 10 x max_speed (only the
  // batch's own speed check catches it)
  const bool finger = GENERATE(true, false);
  const int dof = finger ? model.hand(Side::kRight)->dof_adr[4]
                         : model.object("object")->dof_adr + 2;
  const double speed = finger ? 1e9 : 10 * model.physics().max_speed;
  INFO((finger ? "rh_FF2" : "egg z") << " velocity " << speed);
  int64_t log_before = mujoco_log_size();
  bidex::test::CaptureOutput capture;
  dirty.data(bad)->qvel[dof] = speed;
  sync_slot(model, dirty, bad);
  const double synced = dirty.slot(bad).qvel[dof];  // sync rewrote the output rows

  random_inputs(model, clean, kForce, kTorque);
  random_inputs(model, dirty, kForce, kTorque);
  step(model, clean);
  step(model, dirty);
  std::string printed = capture.text();
  CHECK(printed.empty());
  CHECK(mujoco_log_size() == log_before);
  CHECK(synced == speed);

  for (int s = 0; s < nslot; ++s) {
    INFO("slot " << s << " fault bits " << dirty.fault[s]);
    if (s == bad) {
      CHECK(dirty.fault[s] != kFaultNone);
      CHECK((dirty.fault[s] & (kFaultExploded | kFaultNonFinite | kFaultMujocoWarn)) != 0);
      CHECK((dirty.fault[s] & kFaultBadInput) == 0);
      if (!finger) CHECK(dirty.fault[s] == kFaultExploded);
    } else {
      CHECK(dirty.fault[s] == kFaultNone);
      check_same_rows(rows_of(dirty, s), rows_of(clean, s), "slot " + std::to_string(s));
    }
    CHECK(dirty.fault_count[s] == (s == bad ? 1 : 0));
    CHECK(dirty.episode[s] == (s == bad ? 1 : 0));
  }
  check_same_rows(rows_of(dirty, bad), rows_of(fresh, bad), "exploded slot vs a fresh slot");
  check_same_mjdata(model.mj(), dirty.data(bad), fresh.data(bad));
}

TEST_CASE("reset_slot gives the same state whatever happened before", "[sim][batch][reset]") {
  const SimModel& model = two_hand_model();
  const int nslot = 4;
  SimBatch used(model, nslot, {2, 9});
  SimBatch fresh(model, nslot, {1, 9});
  for (int k = 0; k < 20; ++k) {
    random_inputs(model, used, kForce, kTorque);
    step(model, used);
  }
  REQUIRE(used.total_faults() == 0);
  // the slot has really moved away from the initial state
  CHECK_FALSE(same_bits(used.slot(2).qpos, fresh.slot(2).qpos, model.nq()));
  random_inputs(model, used, kForce, kTorque);  // inputs written, not yet stepped

  reset_slot(model, used, 2);
  CHECK(used.episode[2] == 1);
  CHECK(used.episode[1] == 0);
  check_same_rows(rows_of(used, 2), rows_of(fresh, 2), "reset slot vs fresh slot");
  check_same_mjdata(model.mj(), used.data(2), fresh.data(2));

  // and it evolves identically from there (no hidden state survives, e.g. warm starts)
  for (int k = 0; k < 5; ++k) {
    random_inputs(model, fresh, kForce, kTorque);
    random_inputs(model, used, kForce, kTorque);
    // the same inputs for slot 2 in both batches (fresh slot 2 is in episode 0, used in 1)
    std::copy_n(fresh.slot(2).ctrl, model.nu(), used.slot(2).ctrl);
    std::copy_n(fresh.slot(2).base_wrench, 12, used.slot(2).base_wrench);
    step(model, fresh);
    step(model, used);
    SlotRows a = rows_of(used, 2), b = rows_of(fresh, 2);
    check_same_rows(a, b, "step " + std::to_string(k) + " after the reset");
  }

  SECTION("reset_all resets every slot and advances every episode") {
    reset_all(model, used);
    SimBatch fresh2(model, nslot, {1, 9});
    for (int s = 0; s < nslot; ++s) {
      CHECK(used.episode[s] == (s == 2 ? 2 : 1));
      check_same_rows(rows_of(used, s), rows_of(fresh2, s), "slot " + std::to_string(s));
    }
  }
  SECTION("resetting twice gives the same state and counts two episodes") {
    reset_slot(model, used, 2);
    reset_slot(model, used, 2);
    CHECK(used.episode[2] == 3);
    SimBatch fresh3(model, nslot, {1, 9});
    check_same_rows(rows_of(used, 2), rows_of(fresh3, 2), "slot 2 reset twice vs a fresh slot");
  }
}

TEST_CASE("the random stream of a slot depends on (seed, slot, episode) only", "[sim][batch][reset]") {
  const SimModel& model = two_hand_model();
  auto draws = [](SimBatch& b, int s) {
    std::vector<uint64_t> out;
    for (int i = 0; i < 8; ++i) out.push_back(b.rng(s).next_u64());
    return out;
  };
  SimBatch a(model, 4, {2, 77});
  SimBatch b(model, 8, {1, 77});  // another slot count and thread count

  // different history: `a` steps slot 2 under random inputs (drawing from its stream)
  for (int k = 0; k < 5; ++k) {
    random_inputs(model, a, kForce, kTorque);
    step(model, a);
  }
  draws(b, 2);  // `b` draws a little from slot 2 directly
  reset_slot(model, a, 2);
  reset_slot(model, b, 2);
  REQUIRE(a.episode[2] == 1);
  REQUIRE(b.episode[2] == 1);
  auto a2 = draws(a, 2);
  CHECK(a2 == draws(b, 2));

  // each of seed, slot and episode changes the stream
  SimBatch c(model, 4, {1, 78});
  reset_slot(model, c, 2);
  CHECK(draws(c, 2) != a2);  // seed
  reset_slot(model, a, 3);
  CHECK(a.episode[3] == 1);
  CHECK(draws(a, 3) != a2);  // slot
  reset_slot(model, a, 2);
  reset_slot(model, b, 2);
  CHECK(a.episode[2] == 2);
  auto a2e2 = draws(a, 2);
  CHECK(a2e2 != a2);  // episode
  CHECK(a2e2 == draws(b, 2));

  // episode 0 (parallel reset at construction) too, whichever thread reset the slot
  SimBatch d(model, 4, {2, 77}), e(model, 6, {1, 77});
  for (int s = 0; s < 4; ++s) CHECK(draws(d, s) == draws(e, s));
  CHECK(draws(d, 0) != draws(d, 1));
}

TEST_CASE("random_inputs fill targets inside the control ranges and bounded wrenches",
          "[sim][batch]") {
  const SimModel& model = two_hand_model();
  const mjModel* m = model.mj();
  SimBatch batch(model, 8, {2, 1});
  random_inputs(model, batch, kForce, kTorque);
  double fmax = 0, tmax = 0;
  for (int s = 0; s < batch.nslot(); ++s) {
    SlotView v = batch.slot(s);
    for (int a = 0; a < m->nu; ++a) {
      CHECK(v.ctrl[a] >= m->actuator_ctrlrange[2 * a]);
      CHECK(v.ctrl[a] <= m->actuator_ctrlrange[2 * a + 1]);
    }
    for (int k = 0; k < 12; ++k) {
      double lim = k % 6 < 3 ? kForce : kTorque;
      CHECK(std::abs(v.base_wrench[k]) <= lim);
      (k % 6 < 3 ? fmax : tmax) = std::max(k % 6 < 3 ? fmax : tmax, std::abs(v.base_wrench[k]));
    }
  }
  CHECK(fmax > 0.5 * kForce);  // really spread over the range
  CHECK(tmax > 0.5 * kTorque);
  CHECK_FALSE(same_bits(batch.slot(0).ctrl, batch.slot(1).ctrl, m->nu));
}

TEST_CASE("soak: 64 slots x 150 control steps of random inputs without a fault",
          "[sim][batch][soak]") {
  const SimModel& model = two_hand_model();
  const int nslot = 64, steps = 150;
  SimBatch batch(model, nslot, {0, 2024});
  int64_t by_kind[4] = {0, 0, 0, 0};
  int64_t log_before = mujoco_log_size();
  bidex::test::CaptureOutput capture;
  for (int k = 0; k < steps; ++k) {
    random_inputs(model, batch, kForce, kTorque);
    step(model, batch);
    for (int s = 0; s < nslot; ++s)
      for (int b = 0; b < 4; ++b)
        if (batch.fault[s] & (1u << b)) ++by_kind[b];
  }
  std::string printed = capture.text();
  INFO("faults: bad input " << by_kind[0] << ", non-finite " << by_kind[1] << ", exploded "
                            << by_kind[2] << ", MuJoCo warning " << by_kind[3] << "; total "
                            << batch.total_faults() << " in " << nslot * steps << " slot-steps");
  CHECK(batch.total_faults() == 0);
  CHECK(printed.empty());
  CHECK(mujoco_log_size() == log_before);
  // the state stays finite and the simulated time adds up
  for (double x : batch.qpos) REQUIRE(std::isfinite(x));
  int wrong_time = 0;
  for (int s = 0; s < nslot; ++s)
    if (std::abs(batch.time[s] - steps * model.physics().control_dt()) > 1e-9) ++wrong_time;
  CHECK(wrong_time == 0);
}

TEST_CASE("a MuJoCo error in one slot faults and resets that slot alone", "[sim][batch][faults]") {
  // two falling boxes with an arena large enough to compile and to fall freely, too small for
  // their contact: MuJoCo raises an out-of-memory error, which would end the process unhandled
  PhysicsOptions p = bidex::test::physics();
  p.memory = 3000;
  SceneBuilder sb(p);
  sb.set_floor(false);
  ObjectSpec box;
  box.name = "low";
  box.pose.pos = {0, 0, 1.0};
  sb.add_object(box);
  box.name = "high";
  box.pose.pos = {0, 0, 1.2};
  sb.add_object(box);
  SimModel model = sb.build("stack_overflow_scene");
  SimBatch batch(model, 3, {2, 5});
  const ObjectIndex& high = *model.object("high");

  // slot 1: the upper box is thrown down onto the lower one; the others fall side by side
  batch.data(1)->qvel[high.dof_adr + 2] = -6.0;
  sync_slot(model, batch, 1);
  bool faulted = false;
  for (int k = 0; k < 10 && !faulted; ++k) {
    step(model, batch);
    faulted = batch.fault[1] != kFaultNone;
    CHECK(batch.fault[0] == kFaultNone);
    CHECK(batch.fault[2] == kFaultNone);
  }
  REQUIRE(faulted);
  CHECK(batch.fault[1] == kFaultMujocoError);
  CHECK(batch.fault_count[1] == 1);
  CHECK(batch.episode[1] == 1);
  CHECK(batch.data(1)->pstack == 0);
  CHECK(batch.data(1)->parena == 0);
  // reset to the initial pose, the other slots still falling undisturbed
  CHECK(batch.qpos[1 * batch.qpos_width + high.qpos_adr + 2] == Approx(1.2));
  CHECK(batch.qpos[0 * batch.qpos_width + high.qpos_adr + 2] < 1.2);
  CHECK(batch.total_faults() == 1);
}
