// core/rng.h (SlotRng: the same numbers for the same key and draw, different ones for another
// slot, episode or seed) and the stage bodies of tasks/catch_body.h instantiated with float rows
// (the GPU's precision) against the double rows of the CPU path on a stepped catch_underarm.
#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "core/rng.h"
#include "tasks/catch_body.h"
#include "tasks/catch_family.h"
#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

namespace {

std::vector<uint64_t> draws(SlotRng r, int n) {
  std::vector<uint64_t> out;
  for (int i = 0; i < n; ++i) out.push_back(r.next_u64());
  return out;
}

// A float copy of one slot's rows, with pointers into it (the GPU backend's row type).
struct FloatRows {
  std::vector<std::vector<float>> store;
  const float* copy(const double* x, int n) {
    store.emplace_back(x, x + n);
    return store.back().data();
  }
  float* mut(const double* x, int n) {
    store.emplace_back(x, x + n);
    return store.back().data();
  }
};

bool near(double a, double b, double tol) {
  return std::abs(a - b) <= tol * std::max(1.0, std::abs(b));
}

}  // namespace

TEST_CASE("SlotRng: the same key and draw give the same number, other keys other streams",
          "[core][rng]") {
  // Philox4x32-10's published answer for counter 0 and key 0: draw 0 of (seed 0, slot 0,
  // episode 0) is its first two words
  CHECK(SlotRng::make(0, 0, 0).next_u64() == 0x6627e8d5e169c58dull);

  const SlotRng a = SlotRng::make(77, 3, 5);
  const auto ref = draws(a, 64);
  CHECK(draws(SlotRng::make(77, 3, 5), 64) == ref);
  // draw n depends on the key and n only: a stream moved to draw n continues with ref[n]
  for (int n : {1, 2, 7, 33}) {
    SlotRng b = SlotRng::make(77, 3, 5);
    b.draw = static_cast<uint64_t>(n);
    CHECK(b.next_u64() == ref[n]);
  }
  // each of seed, slot and episode gives another stream
  CHECK(draws(SlotRng::make(78, 3, 5), 64) != ref);
  CHECK(draws(SlotRng::make(77, 4, 5), 64) != ref);
  CHECK(draws(SlotRng::make(77, 3, 6), 64) != ref);
  CHECK(draws(SlotRng::make(77, 3, 5 + (1ull << 32)), 64) != ref);
  // rekeying is a fresh stream of the new episode
  SlotRng c = a;
  c.next_u64();
  c.rekey(6);
  CHECK(draws(c, 64) == draws(SlotRng::make(77, 3, 6), 64));
  // no repeats within a stream or across neighbouring slots
  std::set<uint64_t> seen;
  for (uint32_t s = 0; s < 16; ++s)
    for (uint64_t x : draws(SlotRng::make(77, s, 5), 256)) seen.insert(x);
  CHECK(seen.size() == 16 * 256);
  // uniform: in [lo, hi), mean near the middle
  SlotRng u = SlotRng::make(1, 2, 3);
  double sum = 0;
  for (int i = 0; i < 20000; ++i) {
    const double x = u.uniform(-1, 1);
    REQUIRE(x >= -1);
    REQUIRE(x < 1);
    sum += x;
  }
  CHECK(std::abs(sum / 20000) < 0.02);
}

TEST_CASE("SimBatch rekeys a slot's stream at every reset: (seed, slot, episode)", "[sim][rng]") {
  auto env = make_env("catch_underarm", 3, 41);
  auto& b = env->batch();
  for (int s = 0; s < 3; ++s) {
    const SlotRng& r = b.rng(s);
    CHECK(r.seed == 41);
    CHECK(r.slot == static_cast<uint32_t>(s));
    CHECK(r.episode == static_cast<uint64_t>(b.episode[s]));
  }
}

TEST_CASE("catch bodies with float rows agree with double rows on a stepped catch_underarm",
          "[tasks][body]") {
  auto env = make_env("catch_underarm", 2, 7, 1);
  const auto& task = dynamic_cast<const tasks::CatchTask&>(env->task());
  const tasks::CatchProgram& prog = task.program();
  const auto& m = env->model();
  const int na = env->spec().act.dim(), no = env->spec().obs.dim();
  std::vector<float> a(static_cast<size_t>(2) * na);
  std::mt19937_64 rng(3);
  for (int i = 0; i < 12; ++i) {
    random_actions(a, rng, -0.5f, 0.5f);
    env->step(a);
  }
  const int s = 0;
  const sim::SlotView v = env->batch().slot(s);
  const sim::WorldRows<double> wd = tasks::world_rows(v);
  FloatRows f;
  sim::WorldRows<float> wf;
  wf.qpos = f.copy(v.qpos, m.nq());
  wf.qvel = f.copy(v.qvel, m.nv());
  wf.qfrc_actuator = f.copy(v.qfrc_actuator, m.nv());
  wf.qfrc_constraint = f.copy(v.qfrc_constraint, m.nv());
  wf.sensordata = f.copy(v.sensordata, m.nsensordata());
  wf.xpos = f.copy(v.xpos, m.nbody() * 3);
  wf.xquat = f.copy(v.xquat, m.nbody() * 4);
  wf.cvel = f.copy(v.cvel, m.nbody() * 6);
  wf.subtree_com = f.copy(v.subtree_com, m.nbody() * 3);
  wf.ctrl = f.mut(v.ctrl, m.nu());
  wf.base_wrench = f.mut(v.base_wrench, m.nwrench());

  SECTION("observe") {
    const tasks::SlotState st = env->slot_state(s);
    std::vector<float> od(no), of(no);
    tasks::catch_observe(prog, wd, st, od.data());
    tasks::catch_observe(prog, wf, st, of.data());
    for (int k = 0; k < no; ++k) {
      INFO("obs " << k << ": double " << od[k] << ", float " << of[k]);
      // base orientation angles wrap at 2 pi: a float angle may land on the other side
      const double d = std::abs(od[k] - of[k]);
      CHECK((near(of[k], od[k], 1e-4) || std::abs(d - 2 * M_PI) < 1e-4));
    }
  }
  SECTION("evaluate") {
    tasks::SlotState sd = env->slot_state(s), sf = sd;
    double td[tasks::kMaxTerms] = {};
    float tf[tasks::kMaxTerms] = {};
    SlotRng rd = SlotRng::make(1, 0, 0), rf = rd;
    const bool dd = tasks::catch_evaluate(prog, wd, sd, rd, td);
    const bool df = tasks::catch_evaluate(prog, wf, sf, rf, tf);
    CHECK(dd == df);
    CHECK(sd.success == sf.success);
    CHECK(sd.bonus_paid == sf.bonus_paid);
    for (int k = 0; k < tasks::kMaxTerms; ++k) {
      INFO("term " << k);
      CHECK(near(tf[k], td[k], 1e-4));
    }
    CHECK(td[prog.t_pose[0]] > 0);
  }
  SECTION("apply_actions") {
    std::vector<float> act(na);
    for (int k = 0; k < na; ++k) act[k] = std::sin(1.0f + k);
    std::vector<double> ctrl(m.nu()), wrench(m.nwrench());
    sim::WorldRows<double> wd2 = wd;
    wd2.ctrl = ctrl.data();
    wd2.base_wrench = wrench.data();
    tasks::catch_apply_actions(prog, act.data(), wd2);
    tasks::catch_apply_actions(prog, act.data(), wf);
    for (int k = 0; k < m.nu(); ++k) CHECK(near(wf.ctrl[k], ctrl[k], 1e-5));
    for (int k = 0; k < m.nwrench(); ++k) CHECK(near(wf.base_wrench[k], wrench[k], 1e-5));
  }
  SECTION("reset") {
    const mjData* d = env->batch().data(s);
    const int nmocap = m.mj()->nmocap;
    std::vector<double> qd(d->qpos, d->qpos + m.nq()), vd(d->qvel, d->qvel + m.nv());
    std::vector<double> cd(m.nu(), 0.0), mpd(3 * nmocap, 0.0), mqd(4 * nmocap, 0.0);
    std::vector<float> qf(qd.begin(), qd.end()), vf(vd.begin(), vd.end());
    std::vector<float> cf(m.nu(), 0.f), mpf(3 * nmocap, 0.f), mqf(4 * nmocap, 0.f);
    sim::ResetRows<double> rd{qd.data(), vd.data(), cd.data(), mpd.data(), mqd.data()};
    sim::ResetRows<float> rf{qf.data(), vf.data(), cf.data(), mpf.data(), mqf.data()};
    tasks::SlotState sd{}, sf{};
    SlotRng gd = SlotRng::make(7, 0, 9), gf = gd;
    tasks::catch_reset(prog, rd, sd, gd);
    tasks::catch_reset(prog, rf, sf, gf);
    CHECK(gd.draw == gf.draw);  // the same draws: the same sampled numbers
    CHECK(gd.draw > 24);        // joint noise, object noise and both rotations drew
    for (int k = 0; k < m.nq(); ++k) CHECK(near(qf[k], qd[k], 1e-6));
    for (int k = 0; k < m.nv(); ++k) CHECK(near(vf[k], vd[k], 1e-6));
    for (int k = 0; k < m.nu(); ++k) CHECK(near(cf[k], cd[k], 1e-6));
    for (int k = 0; k < 3 * nmocap; ++k) CHECK(near(mpf[k], mpd[k], 1e-6));
    for (int k = 0; k < 4 * nmocap; ++k) CHECK(near(mqf[k], mqd[k], 1e-6));
    for (int k = 0; k < 7; ++k) CHECK(sf.goal[0][k] == sd.goal[0][k]);
  }
}
