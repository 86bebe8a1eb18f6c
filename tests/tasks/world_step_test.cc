// tasks/world_step.h: the GPU path's per-world evaluate and observe bodies (run here on the host,
// as WarpTaskEnv's host loop runs them) against a family whose reward and observation a test
// sets: a non-finite reward term, final observation or observation faults the world, and no
// NaN or infinity reaches a row the learner reads. tasks/math.h's isfinite and clip_finite too.
#include <cmath>
#include <limits>
#include <vector>

#include <catch2/catch.hpp>

#include "tasks/math.h"
#include "tasks/world_step.h"

using namespace bidex;
using namespace bidex::tasks;

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// A family of two reward terms (1 and `second`) and two observations (`first_obs`, 7) that
// counts its evaluations.
struct TestBodies {
  struct Program {
    float second = 1.0f;
    float first_obs = 0.5f;
    int* evaluations = nullptr;
  };
  static void reset(const Program&, const sim::ResetRows<float>&, SlotState&, SlotRng&) {}
  static void apply(const Program&, const float*, const sim::WorldRows<float>&) {}
  static bool evaluate(const Program& p, const sim::WorldRows<float>&, SlotState&, SlotRng&,
                       float* terms) {
    *p.evaluations += 1;
    terms[0] = 1.0f;
    terms[1] = p.second;
    return false;
  }
  static void observe(const Program& p, const sim::WorldRows<float>&, const SlotState&,
                      float* o) {
    o[0] = p.first_obs;
    o[1] = 7.0f;
  }
};

// One world's arrays (no simulation rows: the test family reads none).
struct OneWorld {
  static constexpr int kObs = 2, kTerms = 2;
  float none[1] = {};
  uint32_t fault = 0;
  int32_t reset = 0;
  SlotState state{};
  SlotRng rng = SlotRng::make(1, 0, 0);
  float obs[kObs] = {}, final_obs[kObs] = {}, reward = 0, terms[kTerms] = {};
  uint8_t terminated = 0, truncated = 0, success = 0, faulted = 0, held = 0;
  double ep_return = 0, ep_terms[kTerms] = {}, done_return = 0, done_length = 0,
         done_terms[kTerms] = {};
  int64_t done_episodes = 0, done_successes = 0, done_terminated = 0, done_truncated = 0,
          done_faults = 0;
  WorldArrays a{};

  explicit OneWorld(int episode_length) {
    float* n = none;
    a.qpos = a.qvel = a.qfrc_actuator = a.qfrc_constraint = a.sensordata = a.xpos = a.xquat =
        a.cvel = a.subtree_com = a.ctrl = a.base_wrench = a.mocap_pos = a.mocap_quat = n;
    a.fault = &fault;
    a.reset = &reset;
    a.state = &state;
    a.rng = &rng;
    a.obs = obs;
    a.final_obs = final_obs;
    a.reward = &reward;
    a.terms = terms;
    a.terminated = &terminated;
    a.truncated = &truncated;
    a.success = &success;
    a.faulted = &faulted;
    a.ep_return = &ep_return;
    a.ep_terms = ep_terms;
    a.done_return = &done_return;
    a.done_length = &done_length;
    a.done_terms = done_terms;
    a.done_episodes = &done_episodes;
    a.done_successes = &done_successes;
    a.done_terminated = &done_terminated;
    a.done_truncated = &done_truncated;
    a.done_faults = &done_faults;
    a.held = &held;
    a.obs_dim = kObs;
    a.nterms = kTerms;
    a.episode_length = episode_length;
    a.obs_clip = 5.0f;
  }
  void evaluate(const TestBodies::Program& p) { world_evaluate<TestBodies>(p, a, 0); }
  void observe(const TestBodies::Program& p) { world_observe<TestBodies>(p, a, 0); }
};

}  // namespace

TEST_CASE("isfinite and clip_finite tell non-finite values apart and clear them",
          "[tasks][faults]") {
  CHECK(math::isfinite(0.0f));
  CHECK(math::isfinite(std::numeric_limits<float>::max()));
  CHECK(math::isfinite(std::numeric_limits<float>::denorm_min()));
  CHECK(math::isfinite(-1e300));
  CHECK_FALSE(math::isfinite(kNaN));
  CHECK_FALSE(math::isfinite(kInf));
  CHECK_FALSE(math::isfinite(-kInf));
  CHECK_FALSE(math::isfinite(std::numeric_limits<double>::quiet_NaN()));

  float row[5] = {1.0f, -9.0f, 9.0f, -2.5f, 0.0f};
  CHECK(math::clip_finite(row, 5, 5.0f));
  CHECK(std::vector<float>(row, row + 5) == std::vector<float>{1, -5, 5, -2.5f, 0});
  float bad[4] = {kNaN, 9.0f, -kInf, 3.0f};
  CHECK_FALSE(math::clip_finite(bad, 4, 5.0f));
  CHECK(std::vector<float>(bad, bad + 4) == std::vector<float>{0, 5, 0, 3});
}

TEST_CASE("world_evaluate faults a world whose reward term is not finite", "[tasks][faults]") {
  for (float bad : {kNaN, kInf, -kInf}) {
    INFO("the second term is " << bad);
    int evals = 0;
    TestBodies::Program p{1.0f, 0.5f, &evals};
    OneWorld w(100);
    w.evaluate(p);  // a normal step: reward 1 + 1, the episode runs on
    CHECK(w.reward == 2.0f);
    CHECK(w.faulted == 0);
    CHECK(w.reset == 0);
    CHECK(w.ep_return == 2.0);
    p.second = bad;
    w.evaluate(p);
    CHECK(evals == 2);
    CHECK(w.faulted == 1);
    CHECK(w.truncated == 1);
    CHECK(w.terminated == 0);
    CHECK(w.reward == 0.0f);  // the learner never reads the bad value
    CHECK(w.terms[0] == 0.0f);
    CHECK(w.terms[1] == 0.0f);
    CHECK(w.final_obs[0] == 0.0f);
    CHECK(w.final_obs[1] == 0.0f);
    CHECK(w.reset == 1);  // the reset pass starts a new episode
    CHECK(w.done_faults == 1);
    CHECK(w.done_episodes == 1);
    CHECK(w.done_truncated == 1);
    CHECK(w.done_return == 2.0);  // the episode's record holds the finite steps only
    CHECK(w.done_length == 2.0);
  }
}

TEST_CASE("a non-finite observation is cleared and faults the world at its next step",
          "[tasks][faults]") {
  int evals = 0;
  TestBodies::Program p{1.0f, kNaN, &evals};
  OneWorld w(100);
  w.observe(p);
  CHECK(w.obs[0] == 0.0f);  // cleared
  CHECK(w.obs[1] == 5.0f);  // clipped as ever
  CHECK(w.state.nonfinite_obs);
  w.evaluate(p);
  CHECK(evals == 0);  // the task does not evaluate a world it cannot observe
  CHECK(w.state.progress == 0);
  CHECK(w.faulted == 1);
  CHECK(w.truncated == 1);
  CHECK(w.reward == 0.0f);
  CHECK(w.reset == 1);
  CHECK(w.done_faults == 1);
  // a finite observation leaves the flag clear
  p.first_obs = 0.25f;
  OneWorld ok(100);
  ok.observe(p);
  CHECK(ok.obs[0] == 0.25f);
  CHECK_FALSE(ok.state.nonfinite_obs);
}

TEST_CASE("a non-finite final observation faults the finishing world", "[tasks][faults]") {
  int evals = 0;
  TestBodies::Program p{1.0f, kInf, &evals};
  OneWorld w(1);  // the time limit ends the episode at the first step
  w.evaluate(p);
  CHECK(evals == 1);
  CHECK(w.faulted == 1);
  CHECK(w.truncated == 1);
  CHECK(w.final_obs[0] == 0.0f);
  CHECK(w.final_obs[1] == 0.0f);
  CHECK(w.reward == 0.0f);
  CHECK(w.done_faults == 1);
  // a finite one is a plain time limit
  p.first_obs = 0.5f;
  OneWorld ok(1);
  ok.evaluate(p);
  CHECK(ok.faulted == 0);
  CHECK(ok.truncated == 1);
  CHECK(ok.final_obs[0] == 0.5f);
  CHECK(ok.final_obs[1] == 5.0f);
  CHECK(ok.reward == 2.0f);
  CHECK(ok.done_faults == 0);
}

// Autoreset off (Gymnasium's NEXT_STEP and DISABLED modes on the GPU path): the finishing world
// is held, not marked for the reset pass; its observation is the final one; later steps pay
// nothing and end nothing and leave its observation; a reset pass outside the step (clearing)
// restarts it and clears its outputs.
TEST_CASE("with autoreset off a finished world is held until a clearing reset pass",
          "[tasks][reset]") {
  int evals = 0;
  TestBodies::Program p{1.0f, 0.5f, &evals};
  OneWorld w(2);
  w.a.autoreset = 0;
  w.evaluate(p);
  CHECK(w.reward == 2.0f);
  CHECK(w.held == 0);
  w.evaluate(p);  // the time limit
  CHECK(w.truncated == 1);
  CHECK(w.held == 1);
  CHECK(w.reset == 0);  // not marked: the step's reset pass leaves it
  CHECK(w.obs[0] == 0.5f);
  CHECK(w.obs[1] == 5.0f);  // the final observation (7 clipped to 5)
  CHECK(w.done_episodes == 1);
  w.obs[1] = -1.0f;  // a held world's observation is left as it is
  for (int i = 0; i < 2; ++i) {
    w.evaluate(p);
    w.observe(p);
    CHECK(w.reward == 0.0f);
    CHECK(w.terms[0] == 0.0f);
    CHECK(w.truncated == 0);
    CHECK(w.terminated == 0);
    CHECK(w.obs[1] == -1.0f);
  }
  CHECK(evals == 2);  // the task's own evaluation ran only while the episode lasted
  CHECK(w.done_episodes == 1);
  // the step's reset pass (a fault check marked it) leaves it held; a clearing one restarts it
  w.reset = 1;
  world_reset<TestBodies>(p, w.a, 0);
  CHECK(w.held == 1);
  w.reward = 3.0f;
  w.a.clearing = 1;
  world_reset<TestBodies>(p, w.a, 0);
  CHECK(w.held == 0);
  CHECK(w.reward == 0.0f);
  CHECK(w.state.progress == 0);
  w.a.clearing = 0;
  w.observe(p);
  CHECK(w.obs[1] == 5.0f);
  w.evaluate(p);
  CHECK(evals == 3);
  CHECK(w.reward == 2.0f);
}
