// The manipulation tasks (tasks/manipulation_family.h): bottle_cap, push_block, re_orientation,
// block_stack, grasp_and_place. Layouts against the paper's index tables (written out here),
// each reward term against values worked out by hand on crafted states, an oracle per task
// (the object driven into its goal state directly: success fires and the goal term is at its
// best; the opposite state does not succeed), reset ranges, random-action smoke runs at 3 and
// 16 slots, determinism over thread counts, strict YAML errors, and a 50k slot-step soak each.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "tasks/block_stack/block_stack.h"
#include "tasks/bottle_cap/bottle_cap.h"
#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

namespace {

const std::array<const char*, 5> kIds = {"bottle_cap", "push_block", "re_orientation",
                                         "block_stack", "grasp_and_place"};

struct Row {
  const char* name;
  int first, last;  // inclusive, as the paper prints them
};

const std::vector<Row> kHands = {
    {"right.dof_pos", 0, 23},          {"right.dof_vel", 24, 47},
    {"right.dof_force", 48, 71},       {"right.fingertip_state", 72, 136},
    {"right.fingertip_force", 137, 166}, {"right.base_pos", 167, 169},
    {"right.base_rot", 170, 172},      {"right.actions", 173, 198},
    {"left.dof_pos", 199, 222},        {"left.dof_vel", 223, 246},
    {"left.dof_force", 247, 270},      {"left.fingertip_state", 271, 335},
    {"left.fingertip_force", 336, 365}, {"left.base_pos", 366, 368},
    {"left.base_rot", 369, 371},       {"left.actions", 372, 397},
};
const std::vector<Row> kActions = {
    {"right.joints", 0, 19},           {"right.base_translation", 20, 22},
    {"right.base_rotation", 23, 25},   {"left.joints", 26, 45},
    {"left.base_translation", 46, 48}, {"left.base_rotation", 49, 51},
};

struct PaperLayout {
  const char* id;
  int obs_dim, episode_length;
  std::vector<Row> tail;
  std::vector<std::string> terms;
};

const std::vector<PaperLayout>& layouts() {
  static const std::vector<PaperLayout> l = {
      {"bottle_cap", 414, 125,
       {{"bottle.pose", 398, 404}, {"bottle.linvel", 405, 407}, {"bottle.angvel", 408, 410},
        {"cap.pos", 411, 413}},
       {"offset", "right_hand", "left_hand", "cap_open"}},
      {"push_block", 417, 125,
       {{"block1.pose", 398, 404}, {"block1.linvel", 405, 407}, {"block1.angvel", 408, 410},
        {"block1.pos", 411, 413}, {"block2.pos", 414, 416}},
       {"offset", "left_hand", "right_hand", "goal"}},
      {"re_orientation", 446, 600,
       {{"object1.pose", 398, 404}, {"object1.linvel", 405, 407}, {"object1.angvel", 408, 410},
        {"goal1.pose", 411, 417}, {"goal1.rot_diff", 418, 421}, {"object2.pose", 422, 428},
        {"object2.linvel", 429, 431}, {"object2.angvel", 432, 434}, {"goal2.pose", 435, 441},
        {"goal2.rot_diff", 442, 445}},
       {"position", "rotation1", "rotation2", "goal_bonus", "action_penalty", "rotation_progress"}},
      {"block_stack", 428, 250,
       {{"block1.pose", 398, 404}, {"block1.linvel", 405, 407}, {"block1.angvel", 408, 410},
        {"goal.pose", 411, 417}, {"goal.rot_diff", 418, 421}, {"block1.pos", 422, 424},
        {"block2.pos", 425, 427}},
       {"offset", "left_hand", "right_hand", "goal", "stack_bonus"}},
      // no paper table: the original's 425 (bucket 13, bucket link pos 3 + quat 4, object 3 + 4)
      {"grasp_and_place", 425, 500,
       {{"bucket.pose", 398, 404}, {"bucket.linvel", 405, 407}, {"bucket.angvel", 408, 410},
        {"bucket_link.pos", 411, 413}, {"bucket_link.quat", 414, 417}, {"object.pos", 418, 420},
        {"object.quat", 421, 424}},
       {"right_hand", "left_hand", "place"}},
  };
  return l;
}

void check_rows(const tasks::Layout& l, const std::vector<Row>& rows) {
  REQUIRE(l.slices().size() == rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto& s = l.slices()[i];
    INFO("paper row " << rows[i].name << " " << rows[i].first << "-" << rows[i].last);
    CHECK(s.name == rows[i].name);
    CHECK(s.start == rows[i].first);
    CHECK(s.end() - 1 == rows[i].last);
    CHECK(s.goal == (std::string(rows[i].name).rfind("goal", 0) == 0));
  }
}

int term(const tasks::TaskEnv& env, const std::string& name) {
  const int k = env.spec().term_index(name);
  INFO("term " << name);
  REQUIRE(k >= 0);
  return k;
}

using Vec = std::array<double, 3>;

// The reward points, computed here from MuJoCo's frames (not with tasks/hands.cc):
// fingertip = distal body origin + 0.02 m along its z; palm = palm origin + 0.08 z - 0.02 y.
Vec local_point(tasks::TaskEnv& env, int s, const std::string& body, const Vec& local) {
  const mjData* d = env.batch().data(s);
  const int b = body_id(env, body);
  double R[9];
  mju_quat2Mat(R, d->xquat + 4 * b);
  Vec out;
  for (int r = 0; r < 3; ++r)
    out[r] = d->xpos[3 * b + r] + R[3 * r] * local[0] + R[3 * r + 1] * local[1] + R[3 * r + 2] * local[2];
  return out;
}
double dist(const Vec& a, const double* b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
}
double tip_sum(tasks::TaskEnv& env, int s, const std::string& pre, const double* p) {
  double sum = 0;
  for (const char* f : {"ffdistal", "mfdistal", "rfdistal", "lfdistal", "thdistal"})
    sum += dist(local_point(env, s, pre + f, {0, 0, 0.02}), p);
  return sum;
}
const double* xpos(tasks::TaskEnv& env, int s, const std::string& body) {
  return env.batch().data(s)->xpos + 3 * body_id(env, body);
}

int joint_qpos(tasks::TaskEnv& env, const std::string& name) {
  const int j = mj_name2id(env.model().mj(), mjOBJ_JOINT, name.c_str());
  INFO("joint " << name);
  REQUIRE(j >= 0);
  return env.model().mj()->jnt_qposadr[j];
}

// Moves a free object to pos (keeping its orientation), at rest.
void move_to(tasks::TaskEnv& env, int s, const std::string& name, const Vec& pos) {
  const auto& o = object_of(env, name);
  mjData* d = env.batch().data(s);
  Q q;
  for (int k = 0; k < 4; ++k) q[k] = d->qpos[o.qpos_adr + 3 + k];
  place_object(env, s, name, pos, q);
}

// Actions that keep both hands where a reset leaves them: every joint target at its present
// angle (0 at the mounts), no base force.
std::vector<float> hold_actions(tasks::TaskEnv& env) {
  std::vector<float> a(static_cast<size_t>(env.act_dim()), 0.f);
  const mjModel* m = env.model().mj();
  const mjData* d = env.batch().data(0);
  for (int h = 0; h < 2; ++h) {
    const auto& hi = env.model().hands()[h];
    for (size_t i = 0; i < hi.actuators.size(); ++i) {
      const double lo = m->actuator_ctrlrange[2 * hi.actuators[i]];
      const double hi_ = m->actuator_ctrlrange[2 * hi.actuators[i] + 1];
      const double q = d->qpos[hi.qpos_adr[hi.actuated[i]]];
      a[h * 26 + i] = static_cast<float>(2 * (q - lo) / (hi_ - lo) - 1);
    }
  }
  return a;
}

Vec plus(const Vec& a, const Vec& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }

}  // namespace

TEST_CASE("manipulation tasks: layouts are the paper's index tables", "[tasks][manip]") {
  for (const auto& p : layouts()) {
    INFO("task " << p.id);
    const auto& sp = tasks::find_task(p.id).spec();
    CHECK(sp.obs.dim() == p.obs_dim);
    CHECK(sp.act.dim() == 52);
    CHECK(sp.free_base);
    CHECK(sp.episode_length == p.episode_length);
    std::vector<Row> rows = kHands;
    rows.insert(rows.end(), p.tail.begin(), p.tail.end());
    check_rows(sp.obs, rows);
    check_rows(sp.act, kActions);
    std::vector<std::string> terms;
    for (auto& t : sp.reward_terms) terms.push_back(t.name);
    CHECK(terms == p.terms);
    REQUIRE(sp.agents.size() == 2);
    for (auto& ag : sp.agents) {
      int od = 0;
      for (auto& n : ag.obs) od += sp.obs.at(n).size;
      CHECK(od == p.obs_dim - 199);
    }
    auto env = make_env(p.id, 1);
    CHECK(env->obs_dim() == p.obs_dim);
    CHECK(env->act_dim() == 52);
    CHECK(env->task().episode_length() == p.episode_length);
  }
}

TEST_CASE("manipulation tasks: observation tails hold what their names say", "[tasks][manip]") {
  for (const char* id : kIds) {
    INFO("task " << id);
    auto env = make_env(id, 2, 5);
    std::vector<float> a(2 * 52, 0.f);
    std::mt19937_64 rng(3);
    random_actions(a, rng);
    env->step(a);  // moving objects
    for (int s = 0; s < 2; ++s) {
      const auto o = observe(*env, s);
      const mjData* d = env->batch().data(s);
      auto at = [&](const std::string& slice, const double* want, int n) {
        const auto& sl = env->spec().obs.at(slice);
        REQUIRE(sl.size >= n);
        for (int k = 0; k < n; ++k) CHECK(o[sl.start + k] == Approx(want[k]).margin(1e-6));
      };
      auto pos_of = [&](const std::string& body) { return d->xpos + 3 * body_id(*env, body); };
      auto xyzw = [&](const std::string& body) {
        const double* q = d->xquat + 4 * body_id(*env, body);
        return std::array<double, 4>{q[1], q[2], q[3], q[0]};
      };
      const std::string sid = id;
      if (sid == "bottle_cap") {
        at("bottle.pose", pos_of("bottle"), 3);
        at("cap.pos", pos_of("bottle_cap"), 3);
      } else if (sid == "push_block" || sid == "block_stack") {
        at("block1.pose", pos_of("block1"), 3);
        at("block1.pos", pos_of("block1"), 3);
        at("block2.pos", pos_of("block2"), 3);
        const auto q = xyzw("block1");
        const auto& sl = env->spec().obs.at("block1.pose");
        for (int k = 0; k < 4; ++k) CHECK(o[sl.start + 3 + k] == Approx(q[k]).margin(1e-6));
      } else if (sid == "re_orientation") {
        at("object1.pose", pos_of("object1"), 3);
        at("object2.pose", pos_of("object2"), 3);
        at("goal1.pose", env->slot_state(s).goal[0].data(), 3);
        at("goal2.pose", env->slot_state(s).goal[1].data(), 3);
      } else {
        at("bucket.pose", pos_of("bucket"), 3);
        at("bucket_link.pos", pos_of("bucket"), 3);
        at("object.pos", pos_of("object"), 3);
        const auto q = xyzw("object");
        at("object.quat", q.data(), 4);
      }
    }
  }
}

// ---- reward terms on crafted states ----------------------------------------------------------

TEST_CASE("bottle_cap terms, reward.variant paper: 0.2 - d_right - d_left + 30 d_open",
          "[tasks][manip][reward]") {
  TaskTempDir pdir;
  auto env =
      make_env("bottle_cap", 1, 3, 0, edited_yaml(pdir, "bottle_cap", {{"variant", "paper"}}));
  CHECK(dynamic_cast<const tasks::BottleCap&>(env->task()).params().reward_variant == "paper");
  const int slide = joint_qpos(*env, "bottle_cap_slide");
  env->batch().data(0)->qpos[slide] = 0.02;  // cap 2 cm off its seat
  sync(*env, 0);
  std::vector<double> t;
  evaluate(*env, 0, t);
  // cap point: bottle origin + R (0, 0, 0.15); right fingertips to it; left palm to the bottle
  const Vec c = local_point(*env, 0, "bottle", {0, 0, 0.15});
  const double* b = xpos(*env, 0, "bottle");
  const Vec palm_l = local_point(*env, 0, "lh_palm", {0, -0.02, 0.08});
  CHECK(t[term(*env, "offset")] == 0.2);
  CHECK(t[term(*env, "right_hand")] == Approx(-tip_sum(*env, 0, "rh_", c.data())).epsilon(1e-9));
  CHECK(t[term(*env, "left_hand")] == Approx(-dist(palm_l, b)).epsilon(1e-9));
  CHECK(t[term(*env, "cap_open")] == Approx(30 * 0.02).epsilon(1e-6));  // 0.6
  CHECK_FALSE(env->slot_state(0).success);                              // 0.02 < 0.03
  // the cap point on the bottle's axis, 15 cm from its origin
  CHECK(dist(c, b) == Approx(0.15).epsilon(1e-9));

  // termination: the cap point at or below 0.5 m (the bottle lowered, hands where they are:
  // the left palm would also be too far, so that limit is switched off here)
  TaskTempDir dir;
  auto env2 = make_env("bottle_cap", 1, 3, 0,
                       edited_yaml(dir, "bottle_cap", {{"max_left_palm", "0"}, {"max_right_palm", "0"}}));
  const auto& bo = object_of(*env2, "bottle");
  mjData* d = env2->batch().data(0);
  sync(*env2, 0);
  const double cz = local_point(*env2, 0, "bottle", {0, 0, 0.15})[2];
  d->qpos[bo.qpos_adr + 2] -= cz - 0.5 + 1e-6;  // c just below 0.5
  sync(*env2, 0);
  CHECK(evaluate(*env2, 0, t));
  d->qpos[bo.qpos_adr + 2] += 2e-3;  // just above
  sync(*env2, 0);
  CHECK_FALSE(evaluate(*env2, 0, t));
  // the left palm 0.2 m from the bottle ends it (default YAML): the bottle moved away
  move_to(*env, 0, "bottle", plus({xpos(*env, 0, "bottle")[0], xpos(*env, 0, "bottle")[1],
                                   xpos(*env, 0, "bottle")[2]}, {0, 0, 0.2}));
  sync(*env, 0);
  const Vec pl = local_point(*env, 0, "lh_palm", {0, -0.02, 0.08});
  CHECK(dist(pl, xpos(*env, 0, "bottle")) >= 0.2);
  CHECK(evaluate(*env, 0, t));

}

TEST_CASE("bottle_cap terms, default (the original's): 2 - d_right - d_left + 30 d_open while "
          "d_right <= 0.3", "[tasks][manip][reward]") {
  auto env = make_env("bottle_cap", 1, 3);
  CHECK(dynamic_cast<const tasks::BottleCap&>(env->task()).params().reward_variant == "original");
  const int slide = joint_qpos(*env, "bottle_cap_slide");
  env->batch().data(0)->qpos[slide] = 0.02;  // cap 2 cm off its seat
  sync(*env, 0);
  std::vector<double> t;
  evaluate(*env, 0, t);
  const Vec c = local_point(*env, 0, "bottle", {0, 0, 0.15});
  const double* b = xpos(*env, 0, "bottle");
  const Vec palm_l = local_point(*env, 0, "lh_palm", {0, -0.02, 0.08});
  const double sr = tip_sum(*env, 0, "rh_", c.data());
  CHECK(t[term(*env, "offset")] == 2);
  CHECK(t[term(*env, "right_hand")] == Approx(-sr).epsilon(1e-9));
  CHECK(t[term(*env, "left_hand")] == Approx(-dist(palm_l, b)).epsilon(1e-9));
  // the gate: the opening pays only while the right fingertips' sum is <= 0.3 (at the mounts
  // it is 0.71)
  CHECK(sr > 0.3);
  CHECK(t[term(*env, "cap_open")] == 0);
  // the right hand's fingertips brought to the cap point (its base shifted by the difference
  // of the point and the tips' centroid): the gate opens, 30 x 0.02
  mjData* d = env->batch().data(0);
  Vec centroid{};
  for (const char* tip : {"ffdistal", "mfdistal", "rfdistal", "lfdistal", "thdistal"}) {
    const Vec p = local_point(*env, 0, std::string("rh_") + tip, {0, 0, 0.02});
    for (int k = 0; k < 3; ++k) centroid[k] += p[k] / 5;
  }
  const auto& rh = env->model().hands()[0];
  for (int k = 0; k < 3; ++k) d->qpos[rh.base_qpos_adr + k] += c[k] - centroid[k];
  sync(*env, 0);
  evaluate(*env, 0, t);
  const double sr_at = tip_sum(*env, 0, "rh_", c.data());
  INFO("right fingertip sum at the cap point " << sr_at);
  REQUIRE(sr_at <= 0.3);
  CHECK(t[term(*env, "right_hand")] == Approx(-sr_at).epsilon(1e-9));
  CHECK(t[term(*env, "cap_open")] == Approx(30 * 0.02).epsilon(1e-6));
}

TEST_CASE("bottle_cap: staying scores more than ending the episode at once",
          "[tasks][manip][reward][exploit]") {
  // zero actions ("still": the episode still ends after 42 steps, the bottle slipping from the
  // left hand) against the quickest end: of the twelve full-force pushes of one base along one
  // axis, the one that ends the episode soonest ("flee"). The default (the original's 2 a step)
  // pays every step of staying; the paper's 0.2 makes every step cost, so ending at once pays
  // more: why it is not the default.
  auto run = [](const std::string& file, int push) {  // push: -1 none, else 0-11
    auto env = make_env("bottle_cap", 1, 3, 1, file);
    env->reset();
    const auto& act = env->spec().act;
    std::vector<float> a(act.dim(), 0.f);
    if (push >= 0) {
      const char* base = push < 6 ? "right.base_translation" : "left.base_translation";
      a[act.at(base).start + (push % 6) / 2] = push % 2 ? -1.f : 1.f;
    }
    double ret = 0, worst = 1e9;
    int steps = 0;
    for (; steps < env->task().episode_length(); ++steps) {
      env->step(a);
      ret += env->reward[0];
      worst = std::min(worst, double(env->reward[0]));
      REQUIRE(env->fault[0] == 0);
      if (env->terminated[0] || env->truncated[0]) {
        ++steps;
        break;
      }
    }
    return std::array<double, 3>{ret, double(steps), worst};
  };
  TaskTempDir dir;
  const auto paper = edited_yaml(dir, "bottle_cap", {{"variant", "paper"}});
  int quickest = 0;
  double fewest = 1e9;
  for (int push = 0; push < 12; ++push) {
    const double steps = run("", push)[1];
    if (steps < fewest) fewest = steps, quickest = push;
  }
  const auto still = run("", -1), flee = run("", quickest);
  const auto still_p = run(paper, -1), flee_p = run(paper, quickest);
  INFO("push " << quickest << "; default: still " << still[0] << " (" << still[1]
                << " steps, worst step " << still[2] << "), flee " << flee[0] << " ("
                << flee[1] << " steps); paper: still " << still_p[0] << ", flee " << flee_p[0]);
  CHECK(flee[1] < still[1]);
  CHECK(still[2] > 0);  // every step of staying pays
  CHECK(still[0] > flee[0]);
  CHECK(still_p[0] < flee_p[0]);
}

TEST_CASE("push_block terms: 2 - d_left - d_right + 5 (0.8 - d_target), each block to its own goal",
          "[tasks][manip][reward]") {
  auto env = make_env("push_block", 1, 3);
  const Vec g1{-0.2, -0.2, 0.625}, g2{-0.2, 0.2, 0.625};
  move_to(*env, 0, "block1", plus(g1, {0.03, 0, 0}));
  move_to(*env, 0, "block2", plus(g2, {0, 0.04, 0}));
  sync(*env, 0);
  std::vector<double> t;
  const bool ended = evaluate(*env, 0, t);
  const double sl = tip_sum(*env, 0, "lh_", xpos(*env, 0, "block1"));
  const double sr = tip_sum(*env, 0, "rh_", xpos(*env, 0, "block2"));
  CHECK(ended == (sl >= 1.2 || sr >= 1.2));  // the hands are still at their mounts: 1.75 m
  CHECK(t[term(*env, "offset")] == 2);
  CHECK(t[term(*env, "goal")] == Approx(5 * (0.8 - 0.07)).epsilon(1e-9));  // 3.65
  CHECK(t[term(*env, "left_hand")] ==
        Approx(-tip_sum(*env, 0, "lh_", xpos(*env, 0, "block1"))).epsilon(1e-9));
  CHECK(t[term(*env, "right_hand")] ==
        Approx(-tip_sum(*env, 0, "rh_", xpos(*env, 0, "block2"))).epsilon(1e-9));
  CHECK(env->slot_state(0).success);  // both within 0.1
  // block 2 at block 1's goal (the original's bug rewarded this): far from its own goal
  env->reset();
  move_to(*env, 0, "block1", g1);
  move_to(*env, 0, "block2", plus(g1, {0, 0, 0.05}));
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "goal")] == Approx(5 * (0.8 - std::hypot(0.4, 0.05))).epsilon(1e-9));
  CHECK_FALSE(env->slot_state(0).success);
}

TEST_CASE("block_stack terms, reward.variant paper: 1.5 - d_left - d_right + 2 (0.24 - d_target)",
          "[tasks][manip][reward]") {
  TaskTempDir pdir;
  auto env =
      make_env("block_stack", 1, 3, 0, edited_yaml(pdir, "block_stack", {{"variant", "paper"}}));
  CHECK(dynamic_cast<const tasks::BlockStack&>(env->task()).params().reward_variant == "paper");
  const Vec t1{0, 0, 0.675}, t2{0, 0, 0.625};
  move_to(*env, 0, "block1", plus(t1, {0.02, 0, 0}));
  move_to(*env, 0, "block2", plus(t2, {0, -0.03, 0}));
  sync(*env, 0);
  std::vector<double> t;
  const bool ended = evaluate(*env, 0, t);
  const double sl = tip_sum(*env, 0, "lh_", xpos(*env, 0, "block1"));
  const double sr = tip_sum(*env, 0, "rh_", xpos(*env, 0, "block2"));
  CHECK(ended == (sl >= 0.75 || sr >= 0.75));
  CHECK(t[term(*env, "offset")] == 1.5);
  // no gate: paid with the hands at their mounts
  CHECK(t[term(*env, "goal")] == Approx(2 * (0.24 - 0.05)).epsilon(1e-9));  // 0.38
  CHECK(t[term(*env, "left_hand")] == Approx(-sl).epsilon(1e-9));
  CHECK(t[term(*env, "right_hand")] == Approx(-sr).epsilon(1e-9));
  CHECK(t[term(*env, "stack_bonus")] == 0);  // not in the paper's formula
  CHECK(env->slot_state(0).success);         // both within 0.07, dz = 0 < 0.03
}

TEST_CASE("block_stack: the original's gate and stack term by default, the paper's formula as a "
          "variant", "[tasks][manip][reward]") {
  // r = 1.5 - S_L - S_R + u + s (upstream.md 6.16): u = 2 (0.24 - |b1 - t1| - |b2 - t2|) while
  // both fingertip sums S are below 0.5 m, s = 50 (0.05 - |z(t1) - z(b1)|) while both blocks are
  // within 0.07 m of their targets (default, version 2); reward.variant paper: u always, no s.
  // Block 1 1 cm above t1 and 2 cm aside (|b1 - t1| = sqrt(5) cm), block 2 3 cm aside of t2.
  const Vec t1{0, 0, 0.675}, t2{0, 0, 0.625};
  const double e = std::sqrt(0.02 * 0.02 + 0.01 * 0.01) + 0.03;  // 0.05236
  TaskTempDir dir;
  const auto paper_file = edited_yaml(dir, "block_stack", {{"variant", "paper"}});
  for (const bool paper : {false, true}) {
    INFO((paper ? "reward.variant paper" : "default (original)"));
    auto env = make_env("block_stack", 1, 3, 0, paper ? paper_file : std::string());
    CHECK(dynamic_cast<const tasks::BlockStack&>(env->task()).params().reward_variant ==
          (paper ? "paper" : "original"));
    auto place = [&] {
      move_to(*env, 0, "block1", plus(t1, {0.02, 0, 0.01}));
      move_to(*env, 0, "block2", plus(t2, {0, -0.03, 0}));
      sync(*env, 0);
    };
    place();
    std::vector<double> t;
    evaluate(*env, 0, t);
    // hands at their mounts: both sums above 0.5, the original's gate shut
    const double sl = tip_sum(*env, 0, "lh_", xpos(*env, 0, "block1"));
    const double sr = tip_sum(*env, 0, "rh_", xpos(*env, 0, "block2"));
    CHECK(sl > 0.5);
    CHECK(sr > 0.5);
    CHECK(t[term(*env, "offset")] == 1.5);
    CHECK(t[term(*env, "left_hand")] == Approx(-sl).epsilon(1e-9));
    CHECK(t[term(*env, "right_hand")] == Approx(-sr).epsilon(1e-9));
    CHECK(t[term(*env, "goal")] == (paper ? Approx(2 * (0.24 - e)).epsilon(1e-9) : Approx(0)));
    CHECK(t[term(*env, "stack_bonus")] ==
          (paper ? Approx(0) : Approx(50 * (0.05 - 0.01)).epsilon(1e-9)));  // 2
    CHECK(env->slot_state(0).success);  // both within 0.07, dz 0.01 < 0.03

    // each hand's fingertips brought to its block (the base shifted by the difference of the
    // block and the tips' centroid): both sums below 0.5, the gate open in both variants
    mjData* d = env->batch().data(0);
    for (int h = 0; h < 2; ++h) {
      const std::string pre = h == 0 ? "rh_" : "lh_";
      const double* b = xpos(*env, 0, h == 0 ? "block2" : "block1");
      Vec c{};
      for (const char* tip : {"ffdistal", "mfdistal", "rfdistal", "lfdistal", "thdistal"}) {
        const Vec q = local_point(*env, 0, pre + tip, {0, 0, 0.02});
        for (int k = 0; k < 3; ++k) c[k] += q[k] / 5;
      }
      const Vec want{b[0], b[1], b[2]};
      const auto& hi = env->model().hands()[h];
      for (int k = 0; k < 3; ++k) d->qpos[hi.base_qpos_adr + k] += want[k] - c[k];
    }
    place();  // the blocks back where they were, at rest
    evaluate(*env, 0, t);
    const double sl_at = tip_sum(*env, 0, "lh_", xpos(*env, 0, "block1"));
    const double sr_at = tip_sum(*env, 0, "rh_", xpos(*env, 0, "block2"));
    INFO("fingertip sums at the blocks: left " << sl_at << ", right " << sr_at);
    REQUIRE(sl_at < 0.5);
    REQUIRE(sr_at < 0.5);
    CHECK(t[term(*env, "left_hand")] == Approx(-sl_at).epsilon(1e-9));
    CHECK(t[term(*env, "right_hand")] == Approx(-sr_at).epsilon(1e-9));
    CHECK(t[term(*env, "goal")] == Approx(2 * (0.24 - e)).epsilon(1e-9));  // 0.375
    CHECK(t[term(*env, "stack_bonus")] ==
          (paper ? Approx(0) : Approx(50 * (0.05 - 0.01)).epsilon(1e-9)));

    // block 2 8 cm from its target: not placed, no stack term in either
    move_to(*env, 0, "block2", plus(t2, {0, -0.08, 0}));
    sync(*env, 0);
    evaluate(*env, 0, t);
    CHECK(t[term(*env, "stack_bonus")] == 0);
    // the stack term goes below 0 with block 1 more than 5 cm off t1's height (both placed)
    move_to(*env, 0, "block2", t2);
    move_to(*env, 0, "block1", plus(t1, {0, 0, -0.06}));
    sync(*env, 0);
    evaluate(*env, 0, t);
    CHECK(t[term(*env, "stack_bonus")] ==
          (paper ? Approx(0) : Approx(50 * (0.05 - 0.06)).epsilon(1e-9)));  // -0.5
  }
}

TEST_CASE("grasp_and_place terms: exp(-10 d_right) + exp(-10 d_left) + 2 exp(-10 |k - c|)",
          "[tasks][manip][reward]") {
  auto env = make_env("grasp_and_place", 1, 3);
  move_to(*env, 0, "object", {0.1, 0.0, 0.625});
  sync(*env, 0);
  std::vector<double> t;
  CHECK_FALSE(evaluate(*env, 0, t));
  const double* k = xpos(*env, 0, "bucket");
  const double* c = xpos(*env, 0, "object");
  CHECK(t[term(*env, "right_hand")] == Approx(std::exp(-10 * tip_sum(*env, 0, "rh_", k))).epsilon(1e-9));
  CHECK(t[term(*env, "left_hand")] == Approx(std::exp(-10 * tip_sum(*env, 0, "lh_", c))).epsilon(1e-9));
  const double d = std::sqrt(0.01 + 0.04 + (0.678 - 0.625) * (0.678 - 0.625));  // 0.2308
  CHECK(t[term(*env, "place")] == Approx(2 * std::exp(-10 * d)).epsilon(1e-9));
  CHECK_FALSE(env->slot_state(0).success);  // 0.23 > 0.2

  // a ball instead of the block: a sphere of diameter 0.05 with density 500 (32.7 g)
  TaskTempDir dir;
  auto env2 = make_env("grasp_and_place", 1, 3, 0,
                       edited_yaml(dir, "grasp_and_place", {{"shape", "ball"}}));
  const int b = body_id(*env2, "object");
  CHECK(env2->model().mj()->body_mass[b] == Approx(500 * 4.0 / 3.0 * M_PI * 0.025 * 0.025 * 0.025));
  CHECK(env2->model().mj()->geom_type[env2->model().mj()->body_geomadr[b]] == mjGEOM_SPHERE);
}

TEST_CASE("re_orientation terms: -10 (d1 + d2) + 1/(theta_i + 0.1) - 0.0002 sum(a^2)",
          "[tasks][manip][reward]") {
  auto env = make_env("re_orientation", 1, 3);
  const Q g = qaxis(0.3, -0.5, 0.8, 1.1);
  set_goal(*env, 0, 0, {0, -0.39, 0.6}, g);
  set_goal(*env, 0, 1, {0, -0.76, 0.6}, g);
  place_object(*env, 0, "object1", {0.02, -0.39, 0.6}, qmul(qaxis(0, 0, 1, 0.3), g));
  place_object(*env, 0, "object2", {0, -0.76, 0.63}, qmul(qaxis(1, 0, 0, 0.5), g));
  sync(*env, 0);
  tasks::TaskSlot sl = env->slot(0);
  for (int k = 0; k < 52; ++k) sl.task->action[k] = k % 2 ? 0.5f : -1.f;  // sum a^2 = 26 x 1.25
  std::vector<double> t;
  CHECK_FALSE(evaluate(*env, 0, t));
  CHECK(t[term(*env, "position")] == Approx(-10 * 0.05).epsilon(1e-9));
  CHECK(t[term(*env, "rotation1")] == Approx(1 / 0.4).epsilon(1e-9));
  CHECK(t[term(*env, "rotation2")] == Approx(1 / 0.6).epsilon(1e-9));
  CHECK(t[term(*env, "action_penalty")] == Approx(-0.0002 * 32.5).epsilon(1e-9));
  CHECK(t[term(*env, "goal_bonus")] == 0);
  // a cube at or below 0.2 m ends the episode
  place_object(*env, 0, "object2", {0, -0.76, 0.2}, g);
  sync(*env, 0);
  CHECK(evaluate(*env, 0, t));
  place_object(*env, 0, "object2", {0, -0.76, 0.21}, g);
  sync(*env, 0);
  CHECK_FALSE(evaluate(*env, 0, t));
}

// ---- oracles ---------------------------------------------------------------------------------

TEST_CASE("oracle: bottle_cap succeeds with the cap pulled off, not with it on", "[tasks][manip][oracle]") {
  // the hands stay at their mounts: the default's gate on the opening term is opened
  TaskTempDir dir;
  auto env = make_env("bottle_cap", 1, 3, 0, edited_yaml(dir, "bottle_cap", {{"goal_gate", "0"}}));
  const int slide = joint_qpos(*env, "bottle_cap_slide");
  std::vector<double> t;
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "cap_open")] == Approx(0).margin(1e-9));
  CHECK_FALSE(env->slot_state(0).success);
  env->batch().data(0)->qpos[slide] = 0.064;  // the slide's limit: the cap off
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(env->slot_state(0).success);
  CHECK(t[term(*env, "cap_open")] == Approx(30 * 0.064).epsilon(1e-6));  // the term's best
  // the cap point moved with the cap? no: it is fixed on the bottle; the cap body moved 6.4 cm
  const double* cap = xpos(*env, 0, "bottle_cap");
  const Vec seat = local_point(*env, 0, "bottle", {0, 0, 0.12});
  CHECK(dist(seat, cap) == Approx(0.064).epsilon(1e-6));
  // and the limit holds: stepping cannot pull it further than 0.064
  std::vector<float> a(52, 0.f);
  for (int i = 0; i < 5; ++i) env->step(a);
  CHECK(env->batch().data(0)->qpos[slide] <= 0.064 + 1e-3);
}

TEST_CASE("oracle: push_block succeeds with both blocks at their own goals", "[tasks][manip][oracle]") {
  auto env = make_env("push_block", 1, 3);
  std::vector<double> t;
  sync(*env, 0);
  evaluate(*env, 0, t);  // blocks at their starts: 0.2 m from their goals each
  CHECK(t[term(*env, "goal")] == Approx(5 * (0.8 - 0.4)).epsilon(1e-6));
  CHECK_FALSE(env->slot_state(0).success);
  // swapped goals (each block at the other's goal): no success
  move_to(*env, 0, "block1", {-0.2, 0.2, 0.625});
  move_to(*env, 0, "block2", {-0.2, -0.2, 0.625});
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK_FALSE(env->slot_state(0).success);
  move_to(*env, 0, "block1", {-0.2, -0.2, 0.625});
  move_to(*env, 0, "block2", {-0.2, 0.2, 0.625});
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(env->slot_state(0).success);
  CHECK(t[term(*env, "goal")] == Approx(5 * 0.8).epsilon(1e-9));  // the term's best
}

TEST_CASE("oracle: block_stack succeeds with block 1 on block 2, not the other way", "[tasks][manip][oracle]") {
  auto env = make_env("block_stack", 1, 3);
  std::vector<double> t;
  move_to(*env, 0, "block1", {0, 0, 0.625});
  move_to(*env, 0, "block2", {0, 0, 0.675});
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK_FALSE(env->slot_state(0).success);
  move_to(*env, 0, "block2", {0, 0, 0.625});
  move_to(*env, 0, "block1", {0, 0, 0.675});
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(env->slot_state(0).success);
  CHECK(t[term(*env, "stack_bonus")] == Approx(50 * 0.05).epsilon(1e-9));  // the term's best
  // the goal term at its best with the gate opened (the hands at their mounts shut it)
  CHECK(t[term(*env, "goal")] == 0);
  {
    TaskTempDir gdir;
    auto env3 = make_env("block_stack", 1, 3, 0,
                         edited_yaml(gdir, "block_stack", {{"goal_gate", "0"}}));
    move_to(*env3, 0, "block2", {0, 0, 0.625});
    move_to(*env3, 0, "block1", {0, 0, 0.675});
    sync(*env3, 0);
    evaluate(*env3, 0, t);
    CHECK(env3->slot_state(0).success);
    CHECK(t[term(*env3, "goal")] == Approx(2 * 0.24).epsilon(1e-9));
  }
  // and the stack stands: 30 steps later block 1 still sits on block 2 (hands held still at
  // their mounts, where the left fingertips' sum to t1, 0.77 m, would end the episode: the
  // termination is switched off for this)
  TaskTempDir dir;
  auto env2 = make_env("block_stack", 1, 3, 0,
                       edited_yaml(dir, "block_stack", {{"max_tip_distance", "0"}}));
  move_to(*env2, 0, "block2", {0, 0, 0.625});
  move_to(*env2, 0, "block1", {0, 0, 0.675});
  sync(*env2, 0);
  const auto a = hold_actions(*env2);
  for (int i = 0; i < 30; ++i) env2->step(a);
  CHECK(xpos(*env2, 0, "block1")[2] == Approx(0.675).margin(0.005));
  CHECK(xpos(*env2, 0, "block2")[2] == Approx(0.625).margin(0.005));
  CHECK(env2->slot_state(0).success);
}

TEST_CASE("oracle: grasp_and_place succeeds with the object in the bucket", "[tasks][manip][oracle]") {
  auto env = make_env("grasp_and_place", 1, 3);
  std::vector<double> t;
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK_FALSE(env->slot_state(0).success);
  const Vec k{xpos(*env, 0, "bucket")[0], xpos(*env, 0, "bucket")[1], xpos(*env, 0, "bucket")[2]};
  move_to(*env, 0, "object", k);  // inside the hollow bucket, touching nothing
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(env->slot_state(0).success);
  CHECK(t[term(*env, "place")] == Approx(2.0).epsilon(1e-9));  // the term's best
}

namespace {

// re_orientation's goal i of slot 0: its orientation and its position
Q re_orientation_goal_q(const tasks::TaskEnv& env, int i) {
  const auto& g = env.slot_state(0).goal[i];
  return Q{g[3], g[4], g[5], g[6]};
}
Vec re_orientation_goal_p(const tasks::TaskEnv& env, int i) {
  const auto& g = env.slot_state(0).goal[i];
  return Vec{g[0], g[1], g[2]};
}

}  // namespace

TEST_CASE("oracle: re_orientation pays the bonus only when both cubes reach their goals",
          "[tasks][manip][oracle]") {
  auto env = make_env("re_orientation", 1, 3);
  std::vector<double> t;
  auto goal_q = [&](int i) { return re_orientation_goal_q(*env, i); };
  auto goal_p = [&](int i) { return re_orientation_goal_p(*env, i); };
  // only cube 2 at its goal (the original fired here): nothing
  place_object(*env, 0, "object1", goal_p(0), qmul(qaxis(0, 1, 0, 0.5), goal_q(0)));
  place_object(*env, 0, "object2", goal_p(1), goal_q(1));
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "goal_bonus")] == 0);
  CHECK_FALSE(env->slot_state(0).success);
  // only cube 1: nothing
  place_object(*env, 0, "object1", goal_p(0), goal_q(0));
  place_object(*env, 0, "object2", goal_p(1), qmul(qaxis(1, 0, 0, 0.5), goal_q(1)));
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "goal_bonus")] == 0);
  CHECK_FALSE(env->slot_state(0).success);
  // both: bonus, success, the rotation terms at their best (1 / 0.1), new goals
  const Q old = goal_q(0);
  place_object(*env, 0, "object2", goal_p(1), goal_q(1));
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "goal_bonus")] == 500);
  CHECK(env->slot_state(0).success);
  CHECK(t[term(*env, "rotation1")] == Approx(10).epsilon(1e-9));
  CHECK(t[term(*env, "rotation2")] == Approx(10).epsilon(1e-9));
  CHECK(t[term(*env, "position")] == Approx(0).margin(1e-9));
  const Q now = goal_q(0);
  CHECK_FALSE((now[0] == old[0] && now[1] == old[1] && now[2] == old[2] && now[3] == old[3]));
  CHECK(now == goal_q(1));  // one shared goal orientation
  const auto& g = object_of(*env, "goal1");
  for (int k = 0; k < 4; ++k) CHECK(env->batch().data(0)->mocap_quat[4 * g.mocap + k] == now[k]);
}

TEST_CASE("oracle: re_orientation's goal_mode each pays each cube at its goal and gives it a new one",
          "[tasks][manip][oracle]") {
  TaskTempDir dir;
  const auto file = edited_yaml(dir, "re_orientation", {{"goal_mode", "each"}});
  auto env = make_env("re_orientation", 1, 3, 0, file);
  std::vector<double> t;
  auto goal_q = [&](int i) { return re_orientation_goal_q(*env, i); };
  auto goal_p = [&](int i) { return re_orientation_goal_p(*env, i); };
  // cube 2 at its goal, cube 1 turned 0.5 rad off: one bonus, a new goal for cube 2 only
  const Q first = goal_q(0);
  place_object(*env, 0, "object1", goal_p(0), qmul(qaxis(0, 1, 0, 0.5), goal_q(0)));
  place_object(*env, 0, "object2", goal_p(1), goal_q(1));
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "goal_bonus")] == 500);
  CHECK(t[term(*env, "rotation2")] == Approx(10).epsilon(1e-9));
  CHECK_FALSE(env->slot_state(0).success);  // success needs both cubes
  CHECK(env->slot_state(0).goals_reached == 2u);
  CHECK(goal_q(0) == first);
  CHECK_FALSE(goal_q(1) == first);
  const auto& g2 = object_of(*env, "goal2");
  for (int k = 0; k < 4; ++k)
    CHECK(env->batch().data(0)->mocap_quat[4 * g2.mocap + k] == goal_q(1)[k]);
  // cube 1 at its goal, cube 2 away from its new one: a bonus, and success
  place_object(*env, 0, "object1", goal_p(0), goal_q(0));
  place_object(*env, 0, "object2", goal_p(1), qmul(qaxis(1, 0, 0, 0.5), goal_q(1)));
  sync(*env, 0);
  const Q second = goal_q(1);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "goal_bonus")] == 500);
  CHECK(env->slot_state(0).success);
  CHECK(env->slot_state(0).goals_reached == 3u);
  CHECK_FALSE(goal_q(0) == first);
  CHECK(goal_q(1) == second);
  // both at once: two bonuses
  place_object(*env, 0, "object1", goal_p(0), goal_q(0));
  place_object(*env, 0, "object2", goal_p(1), goal_q(1));
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "goal_bonus")] == 1000);
}

TEST_CASE("re_orientation's rotation_progress pays each step's decrease of theta1 + theta2, from "
          "a new goal's distance after a goal, and nothing when off", "[tasks][manip][reward]") {
  TaskTempDir dir;
  auto env = make_env("re_orientation", 1, 3, 0,
                      edited_yaml(dir, "re_orientation", {{"rotation_progress", "20"}}));
  const Q g = qaxis(0.3, -0.5, 0.8, 1.1);
  set_goal(*env, 0, 0, {0, -0.39, 0.6}, g);
  set_goal(*env, 0, 1, {0, -0.76, 0.6}, g);
  auto turn = [&](double a1, double a2) {  // cube i a_i rad from its goal
    place_object(*env, 0, "object1", {0, -0.39, 0.6}, qmul(qaxis(0, 0, 1, a1), g));
    place_object(*env, 0, "object2", {0, -0.76, 0.6}, qmul(qaxis(1, 0, 0, a2), g));
    sync(*env, 0);
  };
  std::vector<double> t;
  turn(0.3, 0.5);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "rotation_progress")] == 0);  // the episode's first step: nothing to compare
  turn(0.2, 0.4);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "rotation_progress")] == Approx(20 * (0.1 + 0.1)).epsilon(1e-9));
  turn(0.25, 0.3);  // cube 1 turned away by 0.05, cube 2 on by 0.1
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "rotation_progress")] == Approx(20 * (-0.05 + 0.1)).epsilon(1e-9));
  // both at their goals: the bonus and new goals; the gain up to the goals is paid
  turn(0, 0);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "goal_bonus")] == 500);
  CHECK(t[term(*env, "rotation_progress")] == Approx(20 * (0.25 + 0.3)).epsilon(1e-9));
  // held still at the old goals, now away from the new ones: no charge for the jump of the goal
  const Q now = re_orientation_goal_q(*env, 0);
  CHECK(tasks::math::rot_distance(now.data(), g.data()) > 0.1);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "rotation_progress")] == Approx(0).margin(1e-9));
  // a reset starts the count again
  env->reset();
  place_object(*env, 0, "object1", {0, -0.39, 0.6}, re_orientation_goal_q(*env, 0));
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "rotation_progress")] == 0);

  // off (the default YAML's 0): the term stays 0 while the cubes turn
  auto plain = make_env("re_orientation", 1, 3);
  set_goal(*plain, 0, 0, {0, -0.39, 0.6}, g);
  for (double a : {0.5, 0.2}) {
    place_object(*plain, 0, "object1", {0, -0.39, 0.6}, qmul(qaxis(0, 0, 1, a), g));
    sync(*plain, 0);
    evaluate(*plain, 0, t);
    CHECK(t[term(*plain, "rotation_progress")] == 0);
  }
  CHECK_FALSE(plain->slot_state(0).has_last_error);
  // a negative scale is refused, naming the key
  CHECK_THROWS_WITH(make_env("re_orientation", 1, 3, 0,
                             edited_yaml(dir, "re_orientation", {{"rotation_progress", "-1"}},
                                         "neg.yaml")),
                    Catch::Contains("rotation_progress") && Catch::Contains("-1"));
}

TEST_CASE("re_orientation's training YAML pays 100 per radian of progress on the task's own terms",
          "[tasks][manip][reward]") {
  // PPO's default for this task (configs/train/ppo.yaml) trains under it; the task is its own YAML
  std::string aid = tasks::default_task_config("re_orientation");
  aid.replace(aid.rfind('/') + 1, std::string::npos, "re_orientation_progress.yaml");
  auto env = make_env("re_orientation", 1, 3, 0, aid);
  auto own = make_env("re_orientation", 1, 3);
  const Q g = qaxis(0.3, -0.5, 0.8, 1.1);
  std::vector<double> t, u;
  for (auto* e : {env.get(), own.get()}) {
    set_goal(*e, 0, 0, {0, -0.39, 0.6}, g);
    set_goal(*e, 0, 1, {0, -0.76, 0.6}, g);
  }
  for (double a : {0.5, 0.3}) {
    for (auto* e : {env.get(), own.get()}) {
      place_object(*e, 0, "object1", {0, -0.39, 0.6}, qmul(qaxis(0, 0, 1, a), g));
      place_object(*e, 0, "object2", {0, -0.76, 0.6}, qmul(qaxis(1, 0, 0, a), g));
      sync(*e, 0);
    }
    evaluate(*env, 0, t);
    evaluate(*own, 0, u);
  }
  CHECK(t[term(*env, "rotation_progress")] == Approx(100 * (0.2 + 0.2)).epsilon(1e-9));
  CHECK(u[term(*own, "rotation_progress")] == 0);
  for (const char* k : {"position", "rotation1", "rotation2", "goal_bonus", "action_penalty"})
    CHECK(t[term(*env, k)] == Approx(u[term(*own, k)]).epsilon(1e-12));
}

TEST_CASE("re_orientation's curriculum: goals turned at most level x pi, the level up at each goal "
          "and down at each reset", "[tasks][manip][oracle]") {
  TaskTempDir dir;
  const auto file = edited_yaml(dir, "re_orientation", {{"enabled", "true"}, {"start", "0.5"}});
  auto env = make_env("re_orientation", 64, 3, 0, file);
  const auto& o1 = object_of(*env, "object1");
  auto cube_q = [&](int s) {
    const double* q = env->batch().data(s)->qpos + o1.qpos_adr + 3;
    return Q{q[0], q[1], q[2], q[3]};
  };
  auto angle = [](const Q& a, const Q& b) { return tasks::math::rot_distance(a.data(), b.data()); };
  // every reset: the level down by 0.05 from its start, each slot's goal within level x pi of
  // its cubes' start orientation, spread over that range
  for (int round = 0; round < 3; ++round) {
    if (round > 0) env->reset();
    const double level = 0.5 - 0.05 * round;
    double widest = 0;
    for (int s = 0; s < env->nslot(); ++s) {
      const auto& st = env->slot_state(s);
      CHECK(st.params.level == Approx(level).epsilon(1e-12));
      const Q g{st.goal[0][3], st.goal[0][4], st.goal[0][5], st.goal[0][6]};
      const double a = angle(g, cube_q(s));
      CHECK(a <= level * M_PI + 1e-9);
      widest = std::max(widest, a);
      for (int k = 3; k < 7; ++k) CHECK(st.goal[0][k] == st.goal[1][k]);  // shared, as ever
    }
    CHECK(widest > 0.75 * level * M_PI);
  }
  // both cubes at their goals: the bonus, the level up by 0.02, new goals within its x pi of
  // the old ones
  std::vector<double> t;
  const double level = env->slot_state(0).params.level;
  const Q old = re_orientation_goal_q(*env, 0);
  place_object(*env, 0, "object1", re_orientation_goal_p(*env, 0), old);
  place_object(*env, 0, "object2", re_orientation_goal_p(*env, 1), re_orientation_goal_q(*env, 1));
  sync(*env, 0);
  evaluate(*env, 0, t);
  CHECK(t[term(*env, "goal_bonus")] == 500);
  CHECK(env->slot_state(0).params.level == Approx(level + 0.02).epsilon(1e-12));
  const Q now = re_orientation_goal_q(*env, 0);
  CHECK(angle(now, old) <= (level + 0.02) * M_PI + 1e-9);
  CHECK(angle(now, old) > 0);
  CHECK(now == re_orientation_goal_q(*env, 1));
  // start 0: the goals are the cubes' start orientation
  const auto flat = edited_yaml(dir, "re_orientation", {{"enabled", "true"}, {"start", "0"}},
                                "flat.yaml");
  auto env0 = make_env("re_orientation", 8, 5, 0, flat);
  for (int s = 0; s < env0->nslot(); ++s) {
    const auto& g = env0->slot_state(s).goal[0];
    const double* q = env0->batch().data(s)->qpos + o1.qpos_adr + 3;
    for (int k = 0; k < 4; ++k) CHECK(g[3 + k] == Approx(q[k]).margin(1e-12));
  }
  // set from outside (a resumed run): every slot from its next reset; the stats report them
  env->set_levels(0.7);
  auto st = env->take_stats();
  CHECK(st.levels == 64);
  CHECK(st.level_sum == Approx(64 * 0.7).epsilon(1e-12));
  env->reset();
  CHECK(env->slot_state(5).params.level == Approx(0.65).epsilon(1e-12));
  CHECK_THROWS_WITH(env->set_levels(1.5), Catch::Contains("[0, 1], got 1.5"));
  CHECK(env->take_stats().level_sum == Approx(64 * 0.65).epsilon(1e-12));  // unchanged
  // off (the default): the level is never started, and cannot be set
  auto plain = make_env("re_orientation", 2, 3);
  CHECK_FALSE(plain->slot_state(0).params.level_started);
  CHECK(plain->take_stats().levels == 0);
  CHECK_THROWS_WITH(plain->set_levels(0.5), Catch::Contains("has no curriculum"));
}

// ---- resets ----------------------------------------------------------------------------------

TEST_CASE("re_orientation resets: shared noise and rotation, goals at the starts, hands in range",
          "[tasks][manip][reset]") {
  auto env = make_env("re_orientation", 64, 11);
  const Vec s1{0, -0.39, 0.61}, s2{0, -0.76, 0.61};
  double max_noise = 0;
  for (int round = 0; round < 4; ++round) {
    env->reset();
    for (int s = 0; s < env->nslot(); ++s) {
      const mjData* d = env->batch().data(s);
      const auto& o1 = object_of(*env, "object1");
      const auto& o2 = object_of(*env, "object2");
      for (int k = 0; k < 3; ++k) {
        const double n1 = d->qpos[o1.qpos_adr + k] - s1[k], n2 = d->qpos[o2.qpos_adr + k] - s2[k];
        CHECK(std::abs(n1) <= 0.01 + 1e-12);
        CHECK(n1 == Approx(n2).margin(1e-12));  // one sample for both
        max_noise = std::max(max_noise, std::abs(n1));
      }
      for (int k = 0; k < 4; ++k) CHECK(d->qpos[o1.qpos_adr + 3 + k] == d->qpos[o2.qpos_adr + 3 + k]);
      const auto& st = env->slot_state(s);
      CHECK(st.goal[0][0] == 0);
      CHECK(st.goal[0][1] == -0.39);
      CHECK(st.goal[1][1] == -0.76);
      CHECK(st.goal[0][2] == 0.6);
      for (int k = 3; k < 7; ++k) CHECK(st.goal[0][k] == st.goal[1][k]);
      // hand joints inside their ranges, the same sample for both hands
      const auto& hr = env->model().hands()[0];
      const auto& hl = env->model().hands()[1];
      for (size_t j = 0; j < hr.joints.size(); ++j) {
        const double* r = env->model().mj()->jnt_range + 2 * hr.joints[j];
        const double q = d->qpos[hr.qpos_adr[j]];
        CHECK(q >= r[0] - 1e-9);
        CHECK(q <= r[1] + 1e-9);
        CHECK(q == Approx(d->qpos[hl.qpos_adr[j]]).margin(1e-12));
      }
    }
  }
  CHECK(max_noise > 0.008);  // the range is used
}

TEST_CASE("manipulation tasks: resets restore the start state, inside the hands' reach, no deep contact",
          "[tasks][manip][reset]") {
  for (const char* id : kIds) {
    INFO("task " << id);
    auto env = make_env(id, 4, 21);
    std::vector<float> a(static_cast<size_t>(4) * 52);
    std::mt19937_64 rng(5);
    for (int i = 0; i < 20; ++i) {
      random_actions(a, rng);
      env->step(a);
    }
    env->reset();
    std::vector<double> t;
    for (int s = 0; s < env->nslot(); ++s) {
      const mjData* d = env->batch().data(s);
      // the start state ends nothing
      CHECK_FALSE(evaluate(*env, s, t));
      CHECK_FALSE(env->slot_state(s).success);
      // contacts between the hands and the objects, tables and each other; not those inside one
      // hand: hand_dof_noise 0.2 puts two adjacent distal phalanges 5-14 mm into each other in
      // about 1 reset in 6 (every task with that noise: the sampled joint angles, not the object)
      const mjModel* m = env->model().mj();
      auto tree = [&](int geom) { return m->body_rootid[m->geom_bodyid[geom]]; };
      std::vector<int> hand_trees;
      for (const auto& h : env->model().hands()) hand_trees.push_back(m->body_rootid[h.root_body]);
      double worst = 0;
      for (int c = 0; c < d->ncon; ++c) {
        const int t1 = tree(d->contact[c].geom[0]), t2 = tree(d->contact[c].geom[1]);
        const bool in_one_hand =
            t1 == t2 && std::count(hand_trees.begin(), hand_trees.end(), t1) > 0;
        if (!in_one_hand) worst = std::min(worst, d->contact[c].dist);
      }
      CHECK(worst > -0.005);
      if (std::string(id) == "bottle_cap") {
        CHECK(d->qpos[joint_qpos(*env, "bottle_cap_slide")] == 0);
        CHECK(d->qpos[joint_qpos(*env, "bottle_cap_twist")] == 0);
      }
      if (std::string(id) == "push_block") {
        const auto& b = object_of(*env, "block1");
        CHECK(d->qpos[b.qpos_adr + 1] == -0.2);
        CHECK(d->qpos[b.qpos_adr + 2] == 0.625);
      }
    }
  }
}

// ---- rollouts --------------------------------------------------------------------------------

TEST_CASE("manipulation tasks: random actions give finite results at 3 and 16 slots",
          "[tasks][manip][rollout]") {
  for (const char* id : kIds) {
    for (int n : {3, 16}) {
      INFO("task " << id << ", " << n << " slots");
      auto env = make_env(id, n, 9);
      std::vector<float> a(static_cast<size_t>(n) * env->act_dim());
      std::mt19937_64 rng(4);
      int64_t faults = 0;
      for (int i = 0; i < 40; ++i) {
        random_actions(a, rng);
        env->step(a);
        faults += env->take_stats().faults;
        for (float x : env->obs) REQUIRE(std::isfinite(x));
        for (float x : env->reward) REQUIRE(std::isfinite(x));
        for (float x : env->terms) REQUIRE(std::isfinite(x));
      }
      CHECK(faults == 0);
    }
  }
}

TEST_CASE("manipulation tasks: same seed gives bitwise identical trajectories for 1 and 2 threads",
          "[tasks][manip][determinism]") {
  for (const char* id : kIds) {
    INFO("task " << id);
    std::vector<std::vector<float>> runs;
    for (int threads : {1, 2}) {
      auto env = make_env(id, 4, 77, threads);
      std::vector<float> a(static_cast<size_t>(4) * env->act_dim());
      std::mt19937_64 rng(8);
      std::vector<float> trace;
      for (int i = 0; i < 30; ++i) {
        random_actions(a, rng);
        env->step(a);
        trace.insert(trace.end(), env->obs.begin(), env->obs.end());
        trace.insert(trace.end(), env->reward.begin(), env->reward.end());
      }
      runs.push_back(trace);
    }
    REQUIRE(runs[0].size() == runs[1].size());
    CHECK(std::memcmp(runs[0].data(), runs[1].data(), runs[0].size() * sizeof(float)) == 0);
  }
}

// ---- configuration ---------------------------------------------------------------------------

TEST_CASE("manipulation tasks: bad YAML is a ConfigError naming file, key, expected and actual",
          "[tasks][manip][config]") {
  struct Case {
    const char* id;
    std::function<std::string(std::string)> edit;
    const char* key;
    const char* expected;
    const char* actual;
  };
  const std::vector<Case> cases = {
      {"bottle_cap", [](std::string t) { return t + "colour: red\n"; }, "colour", "one of the keys",
       "unknown key 'colour'"},
      {"bottle_cap", [](std::string t) { return remove_key(t, "cap_travel"); }, "bottle.cap_travel",
       "a value for the required key", "none"},
      {"bottle_cap", [](std::string t) { return set_value(t, "cap_travel", "far"); },
       "bottle.cap_travel", "a number", "far"},
      {"bottle_cap", [](std::string t) { return set_value(t, "cap_travel", "-0.01"); },
       "bottle.cap_travel", "a travel in [0.001, 0.5] m", "-0.01"},
      {"bottle_cap", [](std::string t) { return set_value(t, "variant", "both"); },
       "reward.variant", "'original' or 'paper'", "both"},
      {"bottle_cap", [](std::string t) { return set_value(t, "paper", "{offset: 0.2, gate: 0}"); },
       "reward.paper.gate", "a key of 'reward'", "'gate'"},
      {"push_block", [](std::string t) { return remove_key(t, "goal_offset"); }, "reward.goal_offset",
       "a value for the required key", "none"},
      {"push_block", [](std::string t) { return set_value(t, "density", "-500"); }, "blocks.density",
       "a density in [1, 20000] kg/m^3", "-500"},
      {"push_block", [](std::string t) { return set_value(t, "episode_length", "0"); },
       "episode_length", "an episode length > 0", "0"},
      {"re_orientation", [](std::string t) { return set_value(t, "random_goal_rotation", "maybe"); },
       "reset.random_goal_rotation", "true or false", "maybe"},
      {"re_orientation", [](std::string t) { return set_value(t, "dist_scale", "10"); },
       "reward.dist_scale", "a scale <= 0", "10"},
      {"re_orientation", [](std::string t) { return set_value(t, "goal_mode", "either"); },
       "reward.goal_mode", "'both' or 'each'", "either"},
      {"block_stack", [](std::string t) { return set_value(t, "stack_bonus_scale", "-1"); },
       "reward.stack_bonus_scale", "a scale in [0, 1e4]", "-1"},
      {"block_stack", [](std::string t) { return set_value(t, "variant", "printed"); },
       "reward.variant", "'original' or 'paper'", "printed"},
      {"block_stack",
       [](std::string t) { return set_value(t, "paper", "{goal_gate: 0, bonus_scale: 0}"); },
       "reward.paper.bonus_scale", "a key of 'reward'", "'bonus_scale'"},
      {"block_stack",
       [](std::string t) { return set_value(t, "paper", "{goal_gate: -1, stack_bonus_scale: 0}"); },
       "reward.paper.goal_gate", "a fingertip distance sum in [0, 100] m (0: off)", "-1"},
      {"block_stack", [](std::string t) { return set_value(t, "force_scale", "[1, 2]"); },
       "base.force_scale", "a number", "[1, 2]"},
      {"grasp_and_place", [](std::string t) { return set_value(t, "shape", "banana"); },
       "object.shape", "block or ball", "banana"},
      {"grasp_and_place", [](std::string t) { return set_value(t, "wall", "0.04"); }, "bucket.wall",
       "a wall thinner than half the bucket's half width", "0.04"},
      {"grasp_and_place", [](std::string t) { return set_value(t, "table", "{pos: [0, 0, 0.3], half_size: [0.5, 0, 0.3], friction: 1}"); },
       "table.half_size", "3 half sizes in (0, 10] m", "[0.5, 0, 0.3]"},
  };
  TaskTempDir dir;
  int n = 0;
  for (const auto& c : cases) {
    INFO("task " << c.id << ", key " << c.key);
    const std::string file = dir.write("bad" + std::to_string(n++) + ".yaml", c.edit(default_yaml(c.id)));
    auto e = thrown<ConfigError>([&] { tasks::make_task(c.id, file); });
    const std::string what = e.what();
    INFO("what(): " << what);
    CHECK(e.file().rfind(file, 0) == 0);
    CHECK(contains(what, file));
    CHECK(e.key() == c.key);
    CHECK(contains(e.expected(), c.expected));
    CHECK(contains(e.actual(), c.actual));
    CHECK(contains(what, c.key));
  }
  // every default YAML loads
  for (const char* id : kIds) CHECK_NOTHROW(tasks::make_task(id));
}

// ---- soak ------------------------------------------------------------------------------------
// tests/tasks/task_fixture.h soak_task, on episodes cut to 75 steps so that every slot resets
// inside step
TEST_CASE("soak: bottle_cap: 50k random slot-steps without a fault", "[tasks][manip][soak]") {
  soak_task("bottle_cap", 75);
}
TEST_CASE("soak: push_block: 50k random slot-steps without a fault", "[tasks][manip][soak]") {
  soak_task("push_block", 75);
}
TEST_CASE("soak: re_orientation: 50k random slot-steps without a fault", "[tasks][manip][soak]") {
  soak_task("re_orientation", 75);
}
TEST_CASE("soak: block_stack: 50k random slot-steps without a fault", "[tasks][manip][soak]") {
  soak_task("block_stack", 75);
}
TEST_CASE("soak: grasp_and_place: 50k random slot-steps without a fault", "[tasks][manip][soak]") {
  soak_task("grasp_and_place", 75);
}
