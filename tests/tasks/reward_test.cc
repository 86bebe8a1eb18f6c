// tasks/catch_family evaluate + tasks/env: each reward term against values worked out by hand
// on crafted states (object at a known offset and rotation from its goal), the goal bonus,
// falls and drifts, the action penalty, success, and how the env keeps terminated, truncated
// and success apart over episodes.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

namespace {

using Vec = std::array<double, 3>;

// An orientation that is not special (no axis-aligned symmetry).
const Q kGoalQuat = qaxis(0.3, -0.5, 0.8, 1.1);

// Object i of slot s at `goal + d * dir` (dir normalised here), turned `theta` about `axis`
// relative to the goal orientation kGoalQuat; the goal set to (goal, kGoalQuat).
void craft_pair(tasks::TaskEnv& env, int s, int i, const Vec& goal, double d, Vec dir,
                double theta, const Vec& axis = {0, 0, 1}) {
  const double n = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  const Vec pos{goal[0] + d * dir[0] / n, goal[1] + d * dir[1] / n, goal[2] + d * dir[2] / n};
  const int nobj = env.spec().obs.find("object.pose") ? 1 : 2;
  place_object(env, s, object_name(nobj, i), pos, qmul(qaxis(axis[0], axis[1], axis[2], theta), kGoalQuat));
  set_goal(env, s, i, goal, kGoalQuat);
}

// Index of a reward term by name (fails the test when absent).
int term(const tasks::TaskEnv& env, const std::string& name) {
  const int k = env.spec().term_index(name);
  INFO("term " << name);
  REQUIRE(k >= 0);
  return k;
}

// Keeps every object of slot s floating at rest far from the hands (so no fall, no success).
void park_objects(tasks::TaskEnv& env, int s) {
  const int nobj = env.spec().obs.find("object.pose") ? 1 : 2;
  for (int i = 0; i < nobj; ++i)
    place_object(env, s, object_name(nobj, i), {0.6, 0.3 * i, 1.2}, {1, 0, 0, 0});
}

}  // namespace

TEST_CASE("pose term is exp(-0.2 (alpha d + theta)) with the YAML's alpha",
          "[tasks][reward]") {
  // hand-worked: alpha 50: exp(-0.2 (50 x 0.02 + 0.3)) = exp(-0.26) = 0.771051585803566
  //              alpha 20: exp(-0.2 (20 x 0.02 + 0.3)) = exp(-0.14) = 0.869358235398806
  struct Case {
    const char* id;
    double want;
  };
  for (auto c : {Case{"hand_over", 0.771051585803566}, Case{"catch_underarm", 0.771051585803566},
                 Case{"catch_over2underarm", 0.869358235398806},
                 Case{"catch_abreast", 0.771051585803566}}) {
    INFO("task " << c.id);
    auto env = make_env(c.id, 1, 3);
    const Vec goal = facts(c.id).goal[0];
    std::vector<double> t;
    // d = 0.02 m along an oblique direction, theta = 0.3 rad about z
    craft_pair(*env, 0, 0, goal, 0.02, {1, 2, -2}, 0.3);
    sync(*env, 0);
    CHECK_FALSE(evaluate(*env, 0, t));
    CHECK(t[term(*env, "pose")] == Approx(c.want).epsilon(1e-9));
    // the same about another axis, and the quaternion's sign does not matter
    craft_pair(*env, 0, 0, goal, 0.02, {0, 0, 1}, -0.3, {1, -1, 0.5});
    sync(*env, 0);
    CHECK_FALSE(evaluate(*env, 0, t));
    CHECK(t[term(*env, "pose")] == Approx(c.want).epsilon(1e-9));
    {
      const auto& o = object_of(*env, "object");
      double* q = env->batch().data(0)->qpos + o.qpos_adr + 3;
      for (int k = 0; k < 4; ++k) q[k] = -q[k];
      sync(*env, 0);
      CHECK_FALSE(evaluate(*env, 0, t));
      CHECK(t[term(*env, "pose")] == Approx(c.want).epsilon(1e-9));
    }
    // at the goal: 1; a half turn: exp(-0.2 pi)
    craft_pair(*env, 0, 0, goal, 0, {1, 0, 0}, 0);
    sync(*env, 0);
    evaluate(*env, 0, t);
    CHECK(t[term(*env, "pose")] == Approx(1.0).epsilon(1e-12));
    craft_pair(*env, 0, 0, goal, 0, {1, 0, 0}, M_PI, {0, 1, 0});
    sync(*env, 0);
    evaluate(*env, 0, t);
    CHECK(t[term(*env, "pose")] == Approx(std::exp(-0.2 * M_PI)).epsilon(1e-9));
    // no other term pays by default
    CHECK(t[term(*env, "fall_penalty")] == 0);
    CHECK(t[term(*env, "action_penalty")] == 0);
  }
}

TEST_CASE("two_catch_underarm pays one pose term per object and succeeds on d1 + d2 < 0.06",
          "[tasks][reward]") {
  auto env = make_env("two_catch_underarm", 1, 3);
  const auto& f = facts("two_catch_underarm");
  std::vector<double> t;
  // object 1: d = 0.02, theta = 0.3 -> exp(-0.26) = 0.771051585803566
  // object 2: d = 0.01, theta = 0.1 -> exp(-0.2 (0.5 + 0.1)) = exp(-0.12) = 0.886920436717158
  craft_pair(*env, 0, 0, f.goal[0], 0.02, {1, 0, 0}, 0.3);
  craft_pair(*env, 0, 1, f.goal[1], 0.01, {0, 1, 1}, 0.1, {1, 0, 0});
  sync(*env, 0);
  CHECK_FALSE(evaluate(*env, 0, t));
  CHECK(t[term(*env, "pose_object1")] == Approx(0.771051585803566).epsilon(1e-9));
  CHECK(t[term(*env, "pose_object2")] == Approx(0.886920436717158).epsilon(1e-9));
  CHECK(env->slot_state(0).success);  // 0.02 + 0.01 < 0.06

  // d1 + d2 = 0.04 + 0.03 = 0.07: no success (a fresh episode)
  env->reset();
  craft_pair(*env, 0, 0, f.goal[0], 0.04, {0, 0, 1}, 0);
  craft_pair(*env, 0, 1, f.goal[1], 0.03, {0, 0, 1}, 0);
  sync(*env, 0);
  CHECK_FALSE(evaluate(*env, 0, t));
  CHECK_FALSE(env->slot_state(0).success);
  // each object alone would be within 0.03 of the old one-object rule: 0.03 + 0.029 = 0.059
  craft_pair(*env, 0, 0, f.goal[0], 0.03, {0, 0, 1}, 0);
  craft_pair(*env, 0, 1, f.goal[1], 0.029, {0, 0, 1}, 0);
  sync(*env, 0);
  CHECK_FALSE(evaluate(*env, 0, t));
  CHECK(env->slot_state(0).success);
  CHECK(t[term(*env, "goal_bonus")] == 0);  // no bonus in this task by default

  // either object at the drop height ends the episode
  for (int i = 0; i < 2; ++i) {
    INFO("object " << i + 1);
    craft_pair(*env, 0, 0, f.goal[0], 0, {0, 0, 1}, 0);
    craft_pair(*env, 0, 1, f.goal[1], 0, {0, 0, 1}, 0);
    Vec low = f.goal[i];
    low[2] = 0.2;
    place_object(*env, 0, object_name(2, i), low, {1, 0, 0, 0});
    sync(*env, 0);
    CHECK(evaluate(*env, 0, t));
    low[2] = 0.202;
    place_object(*env, 0, object_name(2, i), low, {1, 0, 0, 0});
    sync(*env, 0);
    CHECK_FALSE(evaluate(*env, 0, t));
  }
}

TEST_CASE("goal bonus pays 250 once per episode in hand_over and nothing in catch_underarm",
          "[tasks][reward]") {
  SECTION("hand_over, through evaluate") {
    auto env = make_env("hand_over", 1, 4);
    const Vec goal = facts("hand_over").goal[0];
    std::vector<double> t;
    const int bonus = term(*env, "goal_bonus");
    // d = 0.031: outside the 0.03 tolerance
    craft_pair(*env, 0, 0, goal, 0.031, {1, 0, 0}, 0.2);
    sync(*env, 0);
    evaluate(*env, 0, t);
    CHECK(t[bonus] == 0);
    CHECK_FALSE(env->slot_state(0).success);
    // d = 0.029: success and the bonus
    craft_pair(*env, 0, 0, goal, 0.029, {1, 0, 0}, 0.2);
    sync(*env, 0);
    evaluate(*env, 0, t);
    CHECK(t[bonus] == 250);
    CHECK(env->slot_state(0).success);
    CHECK(env->slot_state(0).bonus_paid);
    // still there, away, back again: never twice in one episode
    for (double d : {0.0, 0.2, 0.01}) {
      craft_pair(*env, 0, 0, goal, d, {0, 1, 0}, 0);
      sync(*env, 0);
      evaluate(*env, 0, t);
      CHECK(t[bonus] == 0);
      CHECK(env->slot_state(0).success);  // sticky
    }
    // a new episode pays again
    env->reset();
    CHECK_FALSE(env->slot_state(0).success);
    craft_pair(*env, 0, 0, goal, 0.0, {0, 1, 0}, 0);
    sync(*env, 0);
    evaluate(*env, 0, t);
    CHECK(t[bonus] == 250);
  }
  SECTION("hand_over, through step: the reward holds the bonus on the first step only") {
    auto env = make_env("hand_over", 2, 4);
    const Vec goal = facts("hand_over").goal[0];
    std::vector<float> zero(static_cast<size_t>(2 * env->act_dim()), 0.f);
    const int bonus = term(*env, "goal_bonus"), pose = term(*env, "pose");
    for (int step = 0; step < 3; ++step) {
      INFO("step " << step);
      // slot 0: object put back at its goal before each step; slot 1: far away
      craft_pair(*env, 0, 0, goal, 0, {1, 0, 0}, 0);
      park_objects(*env, 1);
      sync(*env, 0);
      sync(*env, 1);
      env->step(zero);
      const float* t0 = env->terms.data();
      CHECK(t0[bonus] == (step == 0 ? 250.f : 0.f));
      CHECK(t0[pose] > 0.9f);  // fell ~mm in one step
      CHECK(env->reward[0] == Approx(t0[pose] + t0[bonus]));
      CHECK(env->success[0] == 1);
      CHECK(env->terms[env->nterms() + bonus] == 0.f);
      CHECK(env->success[1] == 0);
      CHECK_FALSE(env->terminated[0]);
    }
  }
  SECTION("catch_underarm: success without a bonus") {
    auto env = make_env("catch_underarm", 1, 4);
    std::vector<double> t;
    craft_pair(*env, 0, 0, facts("catch_underarm").goal[0], 0.02, {0, 0, 1}, 0.5);
    sync(*env, 0);
    evaluate(*env, 0, t);
    CHECK(env->slot_state(0).success);
    CHECK(t[term(*env, "goal_bonus")] == 0);
  }
}

TEST_CASE("an object at or below the drop height ends the episode but not just above it",
          "[tasks][reward][termination]") {
  for (const auto& f : task_facts()) {
    INFO("task " << f.id << ", drop height " << f.drop_height);
    auto env = make_env(f.id, 1, 6);
    std::vector<double> t;
    // the reset state itself ends nothing
    CHECK_FALSE(evaluate(*env, 0, t));
    for (int i = 0; i < f.nobj; ++i) {
      INFO("object " << i);
      const std::string name = object_name(f.nobj, i);
      Vec p = f.start[i];
      for (double z : {f.drop_height, f.drop_height - 0.05}) {
        p[2] = z;
        place_object(*env, 0, name, p, {1, 0, 0, 0});
        sync(*env, 0);
        CHECK(evaluate(*env, 0, t));
        CHECK(t[term(*env, "fall_penalty")] == 0);  // 0 in every default YAML
      }
      p[2] = f.drop_height + 0.002;
      place_object(*env, 0, name, p, {1, 0, 0, 0});
      sync(*env, 0);
      CHECK_FALSE(evaluate(*env, 0, t));
      place_object(*env, 0, name, f.start[i], {1, 0, 0, 0});
    }
  }
}

TEST_CASE("fall_penalty from the YAML is paid on the step the object falls",
          "[tasks][reward][termination]") {
  TaskTempDir dir;
  for (const char* id : {"hand_over", "catch_underarm"}) {
    INFO("task " << id);
    const auto& f = facts(id);
    auto env = make_env(id, 2, 6, 0, edited_yaml(dir, id, {{"fall_penalty", "-7"}}));
    std::vector<double> t;
    Vec p = f.start[0];
    p[2] = f.drop_height;
    place_object(*env, 0, "object", p, {1, 0, 0, 0});
    sync(*env, 0);
    CHECK(evaluate(*env, 0, t));
    CHECK(t[term(*env, "fall_penalty")] == -7);
    p[2] = f.drop_height + 0.002;
    place_object(*env, 0, "object", p, {1, 0, 0, 0});
    sync(*env, 0);
    CHECK_FALSE(evaluate(*env, 0, t));
    CHECK(t[term(*env, "fall_penalty")] == 0);

    // through step: slot 0 falls (terminated, penalty, final_obs before the reset), slot 1 not
    env->reset();
    p[2] = f.drop_height - 0.02;
    place_object(*env, 0, "object", p, {1, 0, 0, 0});
    park_objects(*env, 1);
    sync(*env, 0);
    sync(*env, 1);
    std::vector<float> zero(static_cast<size_t>(2 * env->act_dim()), 0.f);
    env->step(zero);
    CHECK(env->terminated[0] == 1);
    CHECK(env->truncated[0] == 0);
    CHECK(env->terms[term(*env, "fall_penalty")] == -7.f);
    CHECK(env->terminated[1] == 0);
    CHECK(env->terms[env->nterms() + term(*env, "fall_penalty")] == 0.f);
    CHECK(obs_slice(*env, env->final_obs, 0, "object.pose")[2] <= f.drop_height);
    // obs already shows the next episode's start (within the position noise)
    CHECK(obs_slice(*env, env->obs, 0, "object.pose")[2] ==
          Approx(f.start[0][2]).margin(f.position_noise + 1e-6));
    CHECK(env->slot_state(0).progress == 0);
    auto st = env->take_stats();
    CHECK(st.episodes == 1);
    CHECK(st.terminated == 1);
    CHECK(st.truncated == 0);
    CHECK(st.length_sum == 1);
    CHECK(st.term_sums[term(*env, "fall_penalty")] == -7);
  }
}

TEST_CASE("action penalty is the YAML coefficient x the sum of squared clipped actions",
          "[tasks][reward]") {
  TaskTempDir dir;
  // actions (k mod 5 - 2) x 0.3: squares 0.36, 0.09, 0, 0.09, 0.36 (0.9 per five)
  //   52 actions: 10 x 0.9 + 0.36 + 0.09 = 9.45 -> -0.0002 x 9.45 = -0.00189
  //   40 actions:  8 x 0.9               = 7.2  -> -0.0002 x 7.2  = -0.00144
  struct Case {
    const char* id;
    double want_pattern, want_ones;  // the pattern above; every action at 2.0 (clipped to 1)
  };
  for (auto c : {Case{"hand_over", -0.00144, -0.0002 * 40}, Case{"catch_underarm", -0.00189, -0.0002 * 52},
                 Case{"two_catch_underarm", -0.00189, -0.0002 * 52}}) {
    INFO("task " << c.id);
    const std::string yaml = edited_yaml(dir, c.id, {{"action_penalty", "-0.0002"}});
    auto env = make_env(c.id, 2, 8, 0, yaml);
    const int k = term(*env, "action_penalty");
    tasks::TaskSlot s = env->slot(0);
    for (int i = 0; i < env->act_dim(); ++i) s.task->action[i] = static_cast<float>((i % 5 - 2) * 0.3);
    std::vector<double> t;
    evaluate(*env, 0, t);
    CHECK(t[k] == Approx(c.want_pattern).epsilon(1e-6));

    // through step: actions of 2.0 are clipped to 1 before squaring
    std::vector<float> a(static_cast<size_t>(2 * env->act_dim()), 2.0f);
    env->step(a);
    for (int slot = 0; slot < 2; ++slot) {
      INFO("slot " << slot);
      if (env->terminated[slot] || env->truncated[slot]) continue;
      CHECK(env->terms[static_cast<size_t>(slot) * env->nterms() + k] ==
            Approx(c.want_ones).epsilon(1e-6));
    }
    // the default YAML: zero
    auto plain = make_env(c.id, 1, 8);
    std::vector<float> a1(static_cast<size_t>(plain->act_dim()), 2.0f);
    plain->step(a1);
    CHECK(plain->terms[k] == 0.f);
  }
}

TEST_CASE("catch_over2underarm ends when a base drifts 0.1 m from its mount",
          "[tasks][reward][termination]") {
  for (const char* id : {"catch_over2underarm", "catch_underarm"}) {
    INFO("task " << id << " (catch_underarm has no drift limit)");
    const bool limited = std::string(id) == "catch_over2underarm";
    auto env = make_env(id, 1, 2);
    std::vector<double> t;
    for (const auto& hand : env->model().hands()) {
      INFO("hand " << hand.prefix);
      REQUIRE(hand.base_qpos_adr >= 0);
      mjData* d = env->batch().data(0);
      // the three world-axis slides of the base: |(0.061, 0.08, 0)| = 0.1006, |(0.059, 0.08, 0)| = 0.0994
      for (auto [dx, ends] : {std::pair{0.061, true}, std::pair{0.059, false}}) {
        INFO("offset (" << dx << ", 0.08, 0)");
        d->qpos[hand.base_qpos_adr + 0] = dx;
        d->qpos[hand.base_qpos_adr + 1] = 0.08;
        d->qpos[hand.base_qpos_adr + 2] = 0;
        sync(*env, 0);
        const double* p = env->batch().xpos.data() + 3 * hand.root_body;
        INFO("base at " << p[0] << " " << p[1] << " " << p[2]);
        CHECK(evaluate(*env, 0, t) == (ends && limited));
      }
      for (int k = 0; k < 3; ++k) d->qpos[hand.base_qpos_adr + k] = 0;
      sync(*env, 0);
      CHECK_FALSE(evaluate(*env, 0, t));
    }
  }
}

TEST_CASE("catch_abreast ends when a palm leaves its anchor by 0.1 m",
          "[tasks][reward][termination]") {
  auto env = make_env("catch_abreast", 1, 2);
  std::vector<double> t;
  const Vec anchors[2] = {{-0.3, -0.55, 0.5}, {-0.3, -1.15, 0.5}};  // upstream section 6.4
  for (const auto& hand : env->model().hands()) {
    INFO("hand " << hand.prefix);
    const int palm = body_id(*env, hand.prefix + "palm");
    const Vec a = anchors[hand.side == sim::Side::kRight ? 0 : 1];
    mjData* d = env->batch().data(0);
    const double* p0 = env->batch().xpos.data() + 3 * palm;
    Vec u{p0[0] - a[0], p0[1] - a[1], p0[2] - a[2]};
    const double r0 = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    REQUIRE(r0 < 0.05);  // at reset the palm sits near its anchor
    for (auto& x : u) x /= r0;
    // slide the whole hand along u so that the palm ends 0.103 / 0.097 m from the anchor
    for (auto [target, ends] : {std::pair{0.103, true}, std::pair{0.097, false}}) {
      INFO("palm distance " << target);
      for (int k = 0; k < 3; ++k) d->qpos[hand.base_qpos_adr + k] = (target - r0) * u[k];
      sync(*env, 0);
      const double* p = env->batch().xpos.data() + 3 * palm;
      const double dist = std::sqrt((p[0] - a[0]) * (p[0] - a[0]) + (p[1] - a[1]) * (p[1] - a[1]) +
                                    (p[2] - a[2]) * (p[2] - a[2]));
      REQUIRE(dist == Approx(target).margin(1e-9));
      CHECK(evaluate(*env, 0, t) == ends);
    }
    for (int k = 0; k < 3; ++k) d->qpos[hand.base_qpos_adr + k] = 0;
    sync(*env, 0);
    CHECK_FALSE(evaluate(*env, 0, t));
  }
}

TEST_CASE("episodes are truncated at exactly the episode length and never terminated by it",
          "[tasks][env][termination]") {
  TaskTempDir dir;
  for (const auto& f : task_facts()) {
    INFO("task " << f.id << ", episode length " << f.episode_length);
    // nothing else can end an episode: no drop height, no drift limits
    std::vector<std::pair<std::string, std::string>> edits = {{"drop_height", "-10"}};
    if (std::string(f.id) == "catch_over2underarm") edits.push_back({"max_root_drift", "0"});
    if (std::string(f.id) == "catch_abreast") edits.push_back({"max_palm_drift", "0"});
    auto env = make_env(f.id, 2, 10, 0, edited_yaml(dir, f.id, edits));
    REQUIRE(env->task().episode_length() == f.episode_length);
    std::vector<float> zero(static_cast<size_t>(2 * env->act_dim()), 0.f);
    for (int step = 1; step <= f.episode_length + 1; ++step) {
      env->step(zero);
      for (int s = 0; s < 2; ++s) {
        INFO("step " << step << " slot " << s);
        REQUIRE(env->fault[s] == 0);
        CHECK(env->terminated[s] == 0);
        CHECK(env->truncated[s] == (step == f.episode_length ? 1 : 0));
        CHECK(env->slot_state(s).progress == (step == f.episode_length ? 0 : step % f.episode_length));
      }
    }
    auto st = env->take_stats();
    CHECK(st.episodes == 2);
    CHECK(st.truncated == 2);
    CHECK(st.terminated == 0);
    CHECK(st.faults == 0);
    CHECK(st.length_sum == 2.0 * f.episode_length);
    CHECK(env->take_stats().episodes == 0);  // taken
  }
}

TEST_CASE("a fall on the last step is terminated not truncated and success is sticky until the reset",
          "[tasks][env][termination]") {
  for (const char* id : {"catch_underarm", "catch_abreast"}) {
    INFO("task " << id);
    auto env = make_env(id, 1, 12);
    const auto& f = facts(id);
    const int L = f.episode_length;
    std::vector<float> zero(static_cast<size_t>(env->act_dim()), 0.f);
    for (int step = 1; step <= L; ++step) {
      INFO("step " << step);
      if (step == 3) {
        // at the goal: success from here to the end of the episode
        craft_pair(*env, 0, 0, f.goal[0], 0, {1, 0, 0}, 0);
      } else if (step == L) {
        Vec p = f.start[0];
        p[2] = f.drop_height - 0.03;
        place_object(*env, 0, "object", p, {1, 0, 0, 0});
      } else {
        park_objects(*env, 0);
      }
      // catch_abreast: the hands stay at their mounts (palm drift ends episodes otherwise)
      for (const auto& hand : env->model().hands())
        for (int k = 0; k < 7; ++k)
          env->batch().data(0)->qpos[hand.base_qpos_adr + k] = k == 3 ? 1 : 0;
      sync(*env, 0);
      env->step(zero);
      REQUIRE(env->fault[0] == 0);
      CHECK(env->success[0] == (step >= 3 ? 1 : 0));
      CHECK(env->terminated[0] == (step == L ? 1 : 0));
      CHECK(env->truncated[0] == 0);
    }
    CHECK(env->slot_state(0).progress == 0);
    CHECK_FALSE(env->slot_state(0).success);
    auto st = env->take_stats();
    CHECK(st.episodes == 1);
    CHECK(st.successes == 1);
    CHECK(st.terminated == 1);
    CHECK(st.truncated == 0);
    CHECK(st.length_sum == L);
    // the next episode starts without success
    park_objects(*env, 0);
    sync(*env, 0);
    env->step(zero);
    CHECK(env->success[0] == 0);
    CHECK(env->slot_state(0).progress == 1);
  }
}

TEST_CASE("a NaN action faults only its slot which is truncated and counted",
          "[tasks][env]") {
  auto env = make_env("catch_underarm", 3, 14);
  std::vector<float> a(static_cast<size_t>(3 * env->act_dim()), 0.1f);
  for (int i = 0; i < 5; ++i) env->step(a);
  env->take_stats();
  a[static_cast<size_t>(env->act_dim()) + 4] = std::numeric_limits<float>::quiet_NaN();  // slot 1
  env->step(a);
  CHECK(env->fault[1] == 1);
  CHECK(env->truncated[1] == 1);
  CHECK(env->terminated[1] == 0);
  CHECK(env->fault[0] == 0);
  CHECK(env->fault[2] == 0);
  for (int s = 0; s < 3; ++s)
    for (int k = 0; k < env->obs_dim(); ++k) CHECK(std::isfinite(env->obs[static_cast<size_t>(s) * env->obs_dim() + k]));
  CHECK(env->slot_state(1).progress == 0);
  auto st = env->take_stats();
  CHECK(st.faults == 1);
  CHECK(st.truncated == 1);
  CHECK(st.episodes == 1);
  CHECK(env->batch().total_faults() == 1);
}

namespace {

// catch_underarm, whose slot 1 reports a NaN reward term at its third step of every episode.
class NanRewardTask : public tasks::Task {
 public:
  explicit NanRewardTask(std::unique_ptr<tasks::Task> inner)
      : Task(inner->spec(), inner->config_file()), inner_(std::move(inner)) {}
  int episode_length() const override { return inner_->episode_length(); }
  sim::SceneBuilder scene(const sim::HandSpec& hand, const sim::PhysicsOptions& p) const override {
    return inner_->scene(hand, p);
  }
  void bind(const sim::SimModel& m) override { inner_->bind(m); }
  void reset(tasks::TaskSlot& t) const override { inner_->reset(t); }
  void apply_actions(const float* a, tasks::TaskSlot& t) const override {
    inner_->apply_actions(a, t);
  }
  bool evaluate(tasks::TaskSlot& t, double* terms) const override {
    const bool end = inner_->evaluate(t, terms);
    if (t.index == 1 && t.task->progress == 3) terms[0] = std::nan("");
    return end;
  }
  void observe(const tasks::TaskSlot& t, float* o) const override { inner_->observe(t, o); }

 private:
  std::unique_ptr<tasks::Task> inner_;
};

bool all_finite(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

}  // namespace

TEST_CASE("a non-finite reward faults only its slot, which is truncated, reset and counted",
          "[tasks][env][faults]") {
  tasks::EnvOptions o;
  o.nslot = 3;
  o.seed = 14;
  tasks::TaskEnv env(std::make_unique<NanRewardTask>(tasks::make_task("catch_underarm", "")), o);
  std::vector<float> a(static_cast<size_t>(3 * env.act_dim()), 0.0f);
  env.step(a);
  env.step(a);
  env.take_stats();
  env.step(a);  // slot 1's third step
  CHECK(env.fault == std::vector<uint8_t>{0, 1, 0});
  CHECK(env.truncated[1] == 1);
  CHECK(env.terminated[1] == 0);
  CHECK(env.reward[1] == 0.0f);
  CHECK(env.reward[0] != 0.0f);  // the others are rewarded as ever
  CHECK(all_finite(env.reward));
  CHECK(all_finite(env.terms));
  CHECK(all_finite(env.obs));
  for (int k = 0; k < env.obs_dim(); ++k) CHECK(env.final_obs[env.obs_dim() + k] == 0.0f);
  CHECK(env.slot_state(1).progress == 0);  // a new episode
  const auto st = env.take_stats();
  CHECK(st.faults == 1);
  CHECK(st.episodes == 1);
  CHECK(st.truncated == 1);
  CHECK(std::isfinite(st.return_sum));
  CHECK(env.batch().total_faults() == 0);  // the simulation itself never faulted
  env.step(a);
  CHECK(env.fault == std::vector<uint8_t>{0, 0, 0});
}

TEST_CASE("a non-finite observation is cleared and faults its slot at the next step",
          "[tasks][env][faults]") {
  // slot 2's goal a finite 1e39 m away (double), beyond float: its observed goal is infinite
  auto env = make_env("catch_underarm", 3, 15);
  env->set_goal_shifts({2}, {1e39, 0, 0});
  env->reset();
  CHECK(all_finite(env->obs));
  CHECK(env->slot_state(2).nonfinite_obs);
  CHECK_FALSE(env->slot_state(0).nonfinite_obs);
  std::vector<float> a(static_cast<size_t>(3 * env->act_dim()), 0.0f);
  for (int i = 0; i < 4; ++i) {
    env->step(a);
    // every step ends slot 2's episode (its goal stays out of range) and no other
    CHECK(env->fault == std::vector<uint8_t>{0, 0, 1});
    CHECK(env->truncated[2] == 1);
    CHECK(env->reward[2] == 0.0f);
    CHECK(all_finite(env->obs));
    CHECK(all_finite(env->final_obs));
  }
  const auto st = env->take_stats();
  CHECK(st.faults == 4);
  CHECK(st.episodes == 4);
  CHECK(env->batch().total_faults() == 0);
}
