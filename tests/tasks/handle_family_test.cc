// The two-handle family (lift_underarm, door_open_outward, door_close_inward, door_open_inward,
// door_close_outward) and the shared reward points of tasks/hands.h: layouts against the paper's
// tables, reward terms on crafted states against values worked out here (independently of the
// task's code: handle points from the geometry, fingertip and palm points from mjData's body
// frames), an oracle per task (the object driven into its goal state fires success and gives
// the goal term its best value; the opposite state does not), resets, random-action smoke
// tests, determinism across thread counts, bad YAML errors and a 50k slot-step soak per task.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <cmath>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "tasks/handle_family.h"
#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

namespace {

const std::array<const char*, 5> kIds = {"lift_underarm", "door_open_outward",
                                         "door_close_inward", "door_open_inward",
                                         "door_close_outward"};

// What the paper and upstream.md say of each task (written out here, not read from the YAMLs).
struct DoorFacts {
  const char* id;
  bool inward;       // leaves open towards the hands
  double start;      // leaf angle at reset
  bool open_task;    // success when the handles are wider apart than 0.5 m
  double max_hand;   // termination distance (sum of fingertip distances)
  std::array<double, 3> right_mount;
  double constant;   // the original code's constant per step (the paper's: 0.2)
};
const std::array<DoorFacts, 4> kDoors = {{
    {"door_open_outward", false, 0, true, 1.5, {0.55, 0.2, 0.6}, 2},
    {"door_close_inward", true, M_PI / 2, false, 1.5, {0.9, 0.5, 0.6}, 2},
    {"door_open_inward", true, 0, true, 1.5, {0.55, 0.2, 0.6}, 2},
    {"door_close_outward", false, M_PI / 2, false, 3.0, {0.55, 0.2, 0.6}, 6},
}};

// The door's goal term under a reward variant (upstream.md 6.7, the paper's formulas), from
// the handle points and the fingertip sums: the original (default) pays 2 |dy| (open) or
// 1 - 2 |dy| (close), dy the handles' y-distance, while both sums are below 0.5 m; the paper
// pays 2 d (open) or 2 (1 - d), d the handles' distance, always.
double door_goal(const DoorFacts& f, bool paper, const std::array<double, 3>& hr,
                 const std::array<double, 3>& hl, double dr, double dl) {
  if (paper) {
    const double d = std::sqrt((hr[0] - hl[0]) * (hr[0] - hl[0]) +
                               (hr[1] - hl[1]) * (hr[1] - hl[1]) +
                               (hr[2] - hl[2]) * (hr[2] - hl[2]));
    return f.open_task ? 2 * d : 2 * (1 - d);
  }
  if (!(dr < 0.5 && dl < 0.5)) return 0;
  const double dy = std::abs(hr[1] - hl[1]);
  return f.open_task ? 2 * dy : 1 - 2 * dy;
}

const tasks::HandleTask& handle_task(tasks::TaskEnv& env) {
  return dynamic_cast<const tasks::HandleTask&>(env.task());
}

// A point at `local` in body b's frame, from mjData's xpos/xmat (not the batch's quaternions).
std::array<double, 3> body_point(const mjData* d, int b, const std::array<double, 3>& local) {
  const double* R = d->xmat + 9 * b;
  std::array<double, 3> p{};
  for (int i = 0; i < 3; ++i)
    p[i] = d->xpos[3 * b + i] + R[3 * i] * local[0] + R[3 * i + 1] * local[1] +
           R[3 * i + 2] * local[2];
  return p;
}
double dist(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
}

const char* kTipBodies[5] = {"ffdistal", "mfdistal", "rfdistal", "lfdistal", "thdistal"};
std::string prefix(int h) { return h == 0 ? "rh_" : "lh_"; }

std::array<double, 3> palm_of(tasks::TaskEnv& env, int s, int h) {
  return body_point(env.batch().data(s), body_id(env, prefix(h) + "palm"), {0, -0.02, 0.08});
}
double tip_sum(tasks::TaskEnv& env, int s, int h, const std::array<double, 3>& p) {
  double sum = 0;
  for (const char* t : kTipBodies)
    sum += dist(body_point(env.batch().data(s), body_id(env, prefix(h) + t), {0, 0, 0.02}), p);
  return sum;
}

// Door handle point of leaf h (0 right, 1 left) at hinge angle q, from the geometry: hinge at
// (0, +-0.42, 0) from the door's origin, handle 0.39 m from the hinge towards the middle, 0.04 m
// towards the hands (+x), at the handle height; outward leaves turn towards -x.
std::array<double, 3> door_handle(const std::array<double, 3>& door, double height, bool inward,
                                  int h, double q) {
  const double s = h == 0 ? 1 : -1;          // right leaf on +y
  const double lx = 0.04, ly = -s * 0.39;    // closed-leaf offsets from the hinge
  const double phi = (inward ? 1 : -1) * s * q;  // rotation about +z
  return {door[0] + lx * std::cos(phi) - ly * std::sin(phi),
          door[1] + s * 0.42 + lx * std::sin(phi) + ly * std::cos(phi), door[2] + height};
}

// Shifts hand h's free base (world-axis slides) so that its fingertip points' centroid is at p.
void tips_to(tasks::TaskEnv& env, int s, int h, const std::array<double, 3>& p) {
  mjData* d = env.batch().data(s);
  std::array<double, 3> c{};
  for (const char* t : kTipBodies) {
    const auto x = body_point(d, body_id(env, prefix(h) + t), {0, 0, 0.02});
    for (int k = 0; k < 3; ++k) c[k] += x[k] / 5;
  }
  const auto& hi = env.model().hands()[static_cast<size_t>(h)];
  for (int k = 0; k < 3; ++k) d->qpos[hi.base_qpos_adr + k] += p[k] - c[k];
  sync(env, s);
}

void set_hinges(tasks::TaskEnv& env, int s, double qr, double ql) {
  const auto& task = handle_task(env);
  mjData* d = env.batch().data(s);
  d->qpos[task.hinge_qpos(0)] = qr;
  d->qpos[task.hinge_qpos(1)] = ql;
  d->qvel[task.hinge_dof(0)] = d->qvel[task.hinge_dof(1)] = 0;
  sync(env, s);
}

struct PaperRow {
  const char* name;
  int first, last;
};

}  // namespace

// ---- shared reward points -----------------------------------------------------------------

TEST_CASE("tip_point and palm_point are the original's points on the live bodies",
          "[tasks][handle][hands]") {
  auto env = make_env("lift_underarm", 2, 3, 1);
  env->reset();
  std::vector<float> a(2 * 52);
  std::mt19937_64 rng(5);
  for (int i = 0; i < 5; ++i) {  // move the hands off their reset pose first
    random_actions(a, rng);
    env->step(a);
  }
  const auto& task = handle_task(*env);
  for (int s = 0; s < 2; ++s) {
    tasks::TaskSlot t = env->slot(s);
    for (int h = 0; h < 2; ++h) {
      for (int k = 0; k < 5; ++k) {
        double got[3];
        tasks::tip_point(task.hand(h), t.state, k, got);
        const int b = body_id(*env, prefix(h) + kTipBodies[k]);
        const auto want = body_point(env->batch().data(s), b, {0, 0, 0.02});
        for (int i = 0; i < 3; ++i) CHECK(got[i] == Approx(want[i]).margin(1e-9));
      }
      double got[3];
      tasks::palm_point(task.hand(h), t.state, got);
      const auto want = palm_of(*env, s, h);
      for (int i = 0; i < 3; ++i) CHECK(got[i] == Approx(want[i]).margin(1e-9));
      // the palm point is 0.0825 m from the palm origin
      const double* o = env->batch().data(s)->xpos + 3 * body_id(*env, prefix(h) + "palm");
      CHECK(dist(want, {o[0], o[1], o[2]}) == Approx(std::hypot(0.02, 0.08)).margin(1e-9));
      const std::array<double, 3> p = {0.1, -0.3, 0.7};
      CHECK(tasks::tip_distance_sum(task.hand(h), t.state, p.data()) ==
            Approx(tip_sum(*env, s, h, p)).margin(1e-9));
    }
  }
}

// ---- layouts ------------------------------------------------------------------------------

TEST_CASE("handle tasks: layouts are the paper's tables", "[tasks][handle][layout]") {
  const std::vector<PaperRow> tail = {
      {"object.pose", 398, 404},   {"object.linvel", 405, 407},   {"object.angvel", 408, 410},
      {"goal.pose", 411, 417},     {"goal.rot_diff", 418, 421},   {"right_handle.pos", 422, 424},
      {"left_handle.pos", 425, 427}};
  const std::vector<PaperRow> act = {
      {"right.joints", 0, 19},          {"right.base_translation", 20, 22},
      {"right.base_rotation", 23, 25},  {"left.joints", 26, 45},
      {"left.base_translation", 46, 48}, {"left.base_rotation", 49, 51}};
  for (const char* id : kIds) {
    INFO(id);
    const auto& sp = tasks::find_task(id).spec();
    CHECK(sp.id == id);
    CHECK(sp.obs.dim() == 428);
    CHECK(sp.act.dim() == 52);
    CHECK(sp.free_base);
    CHECK(sp.episode_length == (std::string(id) == "lift_underarm" ? 500 : 250));
    CHECK(sp.age.min_months == (std::string(id) == "lift_underarm" ? 12 : 13));
    CHECK(sp.difficulty == tasks::Difficulty::kEasy);
    // hand blocks 0-198 and 199-397, then the tail in the paper's order, no gaps
    CHECK(sp.obs.at("right.dof_pos").start == 0);
    CHECK(sp.obs.at("left.dof_pos").start == 199);
    CHECK(sp.obs.at("left.actions").end() == 398);
    for (const auto& r : tail) {
      INFO(r.name);
      const auto& s = sp.obs.at(r.name);
      CHECK(s.start == r.first);
      CHECK(s.end() - 1 == r.last);
      CHECK(s.goal == (std::string(r.name).rfind("goal", 0) == 0));
    }
    int goal_slices = 0;
    for (auto& s : sp.obs.slices()) goal_slices += s.goal;
    CHECK(goal_slices == 2);
    REQUIRE(sp.act.slices().size() == act.size());
    for (size_t i = 0; i < act.size(); ++i) {
      CHECK(sp.act.slices()[i].name == act[i].name);
      CHECK(sp.act.slices()[i].start == act[i].first);
      CHECK(sp.act.slices()[i].end() - 1 == act[i].last);
    }
    std::vector<std::string> terms;
    for (auto& t : sp.reward_terms) terms.push_back(t.name);
    CHECK(terms == std::vector<std::string>{"constant", "right_hand", "left_hand", "goal"});
    REQUIRE(sp.agents.size() == 2);
    CHECK(sp.agents[0].obs.back() == "left_handle.pos");
  }
}

// ---- rewards on crafted states ------------------------------------------------------------

TEST_CASE("lift_underarm: reward terms on a crafted state", "[tasks][handle][reward]") {
  auto env = make_env("lift_underarm", 1, 1, 1);
  env->reset();
  // pot lifted 0.1 m, shifted and turned 0.3 rad about z; palms where they are
  const Q q = qaxis(0, 0, 1, 0.3);
  place_object(*env, 0, "pot", {0.02, -0.58, 0.55}, q);
  sync(*env, 0);
  std::vector<double> terms;
  const bool end = evaluate(*env, 0, terms);
  const auto& sp = env->spec();
  // handle points from the pot pose: (0, +-0.15, 0.06) turned by 0.3 about z
  const double c = std::cos(0.3), s = std::sin(0.3);
  const std::array<double, 3> hr = {0.02 - s * 0.15, -0.58 + c * 0.15, 0.61};
  const std::array<double, 3> hl = {0.02 + s * 0.15, -0.58 - c * 0.15, 0.61};
  const double dr = dist(palm_of(*env, 0, 0), hr), dl = dist(palm_of(*env, 0, 1), hl);
  const double dt = dist({0.02, -0.58, 0.55}, {0, -0.6, 0.85});
  CHECK(terms[sp.term_index("constant")] == Approx(0.2));
  CHECK(terms[sp.term_index("right_hand")] == Approx(-dr).margin(1e-9));
  CHECK(terms[sp.term_index("left_hand")] == Approx(-dl).margin(1e-9));
  CHECK(terms[sp.term_index("goal")] == Approx(3 * (0.985 - dt)).margin(1e-9));
  CHECK(end == (dr >= 0.2 || dl >= 0.2));
  CHECK_FALSE(env->slot(0).task->success);
  // the handle slices of the observation
  const auto o = observe(*env, 0);
  for (int k = 0; k < 3; ++k) {
    CHECK(o[422 + k] == Approx(hr[k]).margin(1e-6));
    CHECK(o[425 + k] == Approx(hl[k]).margin(1e-6));
  }
  // goal block: goal point, identity orientation, then the pot's orientation (x, y, z, w)
  CHECK(o[411] == Approx(0));
  CHECK(o[412] == Approx(-0.6));
  CHECK(o[413] == Approx(0.85));
  CHECK(o[417] == Approx(1));
  CHECK(o[420] == Approx(q[3]).margin(1e-6));
  CHECK(o[421] == Approx(q[0]).margin(1e-6));

  // the pot dropped below 0.3 m terminates
  place_object(*env, 0, "pot", {0, -0.6, 0.29}, {1, 0, 0, 0});
  sync(*env, 0);
  CHECK(evaluate(*env, 0, terms));
}

TEST_CASE("lift_underarm: the goal gate and fingertip distances when configured",
          "[tasks][handle][reward]") {
  TaskTempDir dir;
  const auto file = edited_yaml(dir, "lift_underarm",
                                {{"goal_gate", "0.08"}, {"hand_point", "fingertips"},
                                 {"max_hand_distance", "0"}});
  auto env = make_env("lift_underarm", 1, 1, 1, file);
  env->reset();
  std::vector<double> terms;
  evaluate(*env, 0, terms);
  const auto& sp = env->spec();
  const std::array<double, 3> hr = {0, -0.45, 0.51}, hl = {0, -0.75, 0.51};
  CHECK(terms[sp.term_index("right_hand")] == Approx(-tip_sum(*env, 0, 0, hr)).margin(1e-9));
  CHECK(terms[sp.term_index("left_hand")] == Approx(-tip_sum(*env, 0, 1, hl)).margin(1e-9));
  CHECK(tip_sum(*env, 0, 0, hr) > 0.08);
  CHECK(terms[sp.term_index("goal")] == 0.0);  // gated: the hands are not at the handles
}

TEST_CASE("lift_underarm: the goal gate opens with both palms at their handles",
          "[tasks][handle][reward][oracle]") {
  TaskTempDir dir;
  const auto file = edited_yaml(dir, "lift_underarm", {{"goal_gate", "0.08"}});
  auto env = make_env("lift_underarm", 1, 1, 1, file);
  env->reset();
  const auto& sp = env->spec();
  std::vector<double> terms;
  evaluate(*env, 0, terms);
  CHECK(terms[sp.term_index("goal")] == 0.0);  // palms 0.14 m from the handles at the reset
  // shift each free base (world-axis slides) by handle - palm point: the palms at the handles
  const std::array<std::array<double, 3>, 2> handle = {{{0, -0.45, 0.51}, {0, -0.75, 0.51}}};
  mjData* d = env->batch().data(0);
  for (int h = 0; h < 2; ++h) {
    const auto palm = palm_of(*env, 0, h);
    const auto& hi = env->model().hands()[static_cast<size_t>(h)];
    REQUIRE(hi.side == (h == 0 ? sim::Side::kRight : sim::Side::kLeft));
    for (int k = 0; k < 3; ++k) d->qpos[hi.base_qpos_adr + k] += handle[h][k] - palm[k];
  }
  sync(*env, 0);
  evaluate(*env, 0, terms);
  CHECK(-terms[sp.term_index("right_hand")] == Approx(0).margin(1e-9));
  CHECK(-terms[sp.term_index("left_hand")] == Approx(0).margin(1e-9));
  CHECK(terms[sp.term_index("goal")] == Approx(3 * (0.985 - 0.4)).margin(1e-9));
}

TEST_CASE("lift_underarm: reward.variant original is the original code's gated goal term",
          "[tasks][handle][reward]") {
  // the original: 0.2 - d_right - d_left + 3 (0.385 - d_target) while both palms are within
  // 0.08 m of their handles, else 0.2 - d_right - d_left (upstream.md 6.6)
  TaskTempDir dir;
  const auto file = edited_yaml(dir, "lift_underarm", {{"variant", "original"}});
  auto env = make_env("lift_underarm", 1, 1, 1, file);
  env->reset();
  CHECK(handle_task(*env).params().reward_variant == "original");
  const auto& sp = env->spec();
  std::vector<double> terms;
  evaluate(*env, 0, terms);
  CHECK(terms[sp.term_index("constant")] == Approx(0.2));
  CHECK(terms[sp.term_index("goal")] == 0.0);  // palms 0.14 m from the handles
  // palms at the handles: 3 (0.385 - 0.4) with the pot on the table
  const std::array<std::array<double, 3>, 2> handle = {{{0, -0.45, 0.51}, {0, -0.75, 0.51}}};
  mjData* d = env->batch().data(0);
  for (int h = 0; h < 2; ++h) {
    const auto palm = palm_of(*env, 0, h);
    const auto& hi = env->model().hands()[static_cast<size_t>(h)];
    for (int k = 0; k < 3; ++k) d->qpos[hi.base_qpos_adr + k] += handle[h][k] - palm[k];
  }
  sync(*env, 0);
  evaluate(*env, 0, terms);
  CHECK(terms[sp.term_index("goal")] == Approx(3 * (0.385 - 0.4)).margin(1e-9));
  // the pot and both hands lifted 0.4 m: the pot at its goal, 3 x 0.385
  place_object(*env, 0, "pot", {0, -0.6, 0.85}, {1, 0, 0, 0});
  for (const auto& h : env->model().hands()) d->qpos[h.base_qpos_adr + 2] += 0.4;
  sync(*env, 0);
  CHECK_FALSE(evaluate(*env, 0, terms));
  CHECK(terms[sp.term_index("goal")] == Approx(3 * 0.385).margin(1e-9));
  CHECK(env->slot(0).task->success);
}

TEST_CASE("doors: reward terms on crafted states, both variants", "[tasks][handle][reward]") {
  for (const auto& f : kDoors)
    for (const bool paper : {false, true}) {
      INFO(f.id << (paper ? ", reward.variant paper" : ", default (original)"));
      TaskTempDir dir;
      const auto file = paper ? edited_yaml(dir, f.id, {{"variant", "paper"}}) : std::string();
      auto env = make_env(f.id, 1, 1, 1, file);
      env->reset();
      const auto& sp = env->spec();
      CHECK(handle_task(*env).params().reward_variant == (paper ? "paper" : "original"));
      const double height = handle_task(*env).params().door.handle_height;
      const std::array<double, 3> door = {0, 0, 0.7};
      // hands at their mounts (the goal gate shut), then with their fingertips at the handles
      for (const bool at_handles : {false, true})
        for (auto [qr, ql] : {std::pair{0.3, 0.7}, std::pair{1.2, 0.1}, std::pair{0.0, 1.5}}) {
          INFO("hinges " << qr << ", " << ql << (at_handles ? ", hands at the handles" : ""));
          env->reset();
          set_hinges(*env, 0, qr, ql);
          const auto hr = door_handle(door, height, f.inward, 0, qr);
          const auto hl = door_handle(door, height, f.inward, 1, ql);
          if (at_handles) {
            tips_to(*env, 0, 0, hr);
            tips_to(*env, 0, 1, hl);
          }
          std::vector<double> terms;
          const bool end = evaluate(*env, 0, terms);
          const double dr = tip_sum(*env, 0, 0, hr), dl = tip_sum(*env, 0, 1, hl);
          if (at_handles) {  // the gate is open
            CHECK(dr < 0.5);
            CHECK(dl < 0.5);
          } else {
            CHECK(dr > 0.5);
          }
          CHECK(terms[sp.term_index("constant")] == Approx(paper ? 0.2 : f.constant));
          CHECK(terms[sp.term_index("right_hand")] == Approx(-dr).margin(1e-9));
          CHECK(terms[sp.term_index("left_hand")] == Approx(-dl).margin(1e-9));
          CHECK(terms[sp.term_index("goal")] ==
                Approx(door_goal(f, paper, hr, hl, dr, dl)).margin(1e-9));
          CHECK(end == (dr >= f.max_hand || dl >= f.max_hand));
          const auto o = observe(*env, 0);
          for (int k = 0; k < 3; ++k) {
            CHECK(o[422 + k] == Approx(hr[k]).margin(1e-6));
            CHECK(o[425 + k] == Approx(hl[k]).margin(1e-6));
          }
          // the door block: its fixed pose, at rest; the goal block: the same pose
          CHECK(o[398] == Approx(0));
          CHECK(o[400] == Approx(0.7));
          CHECK(o[404] == Approx(1));
          for (int k = 405; k < 411; ++k) CHECK(o[k] == Approx(0).margin(1e-9));
          CHECK(o[413] == Approx(0.7));
          CHECK(o[421] == Approx(1));
        }
    }
}

TEST_CASE("doors: a YAML extending the default selects the paper variant",
          "[tasks][handle][config]") {
  TaskTempDir dir;
  const std::string file = dir.write(
      "paper.yaml", std::string("extends: ") + BIDEX_SOURCE_DIR +
                        "/tasks/door_close_outward/door_close_outward.yaml\n"
                        "reward: {variant: paper}\n");
  auto env = make_env("door_close_outward", 1, 1, 1, file);
  const auto& p = handle_task(*env).params();
  CHECK(p.reward_variant == "paper");
  CHECK(p.constant == 0.2);
  CHECK(p.goal_gate == 0);
  CHECK_FALSE(p.target_y_gap);
  CHECK(p.goal_offset == 1);
  // and the default
  auto def = make_env("door_close_outward", 1, 1, 1);
  const auto& q = handle_task(*def).params();
  CHECK(q.reward_variant == "original");
  CHECK(q.constant == 6);
  CHECK(q.goal_gate == 0.5);
  CHECK(q.target_y_gap);
  CHECK(q.goal_offset == 0.5);
}

TEST_CASE("doors: hand-worked goal terms of the original and the paper formulas",
          "[tasks][handle][reward]") {
  // fingertips at the handles, the right leaf at 0.3 rad and the left at 0.7; the handle points
  // worked out by hand from the geometry (hinges at y = +-0.42, handles 0.39 m in, 0.04 m out):
  // outward, right: y = 0.42 - 0.04 sin 0.3 - 0.39 cos 0.3 = 0.03560
  //          left:  y = -0.42 + 0.04 sin 0.7 + 0.39 cos 0.7 = -0.09594, |dy| = 0.13154
  // inward (the other way round: the 0.04 sin q terms change sign): 0.05924 and -0.14748,
  // |dy| = 0.20672
  for (const auto& f : kDoors) {
    INFO(f.id);
    const double sr = f.inward ? 1 : -1;
    const double yr = 0.42 + sr * 0.04 * std::sin(0.3) - 0.39 * std::cos(0.3);
    const double yl = -0.42 - sr * 0.04 * std::sin(0.7) + 0.39 * std::cos(0.7);
    const double xr = 0.04 * std::cos(0.3) + sr * 0.39 * std::sin(0.3);
    const double xl = 0.04 * std::cos(0.7) + sr * 0.39 * std::sin(0.7);
    const double dy = yr - yl, dist = std::sqrt(dy * dy + (xr - xl) * (xr - xl));
    CHECK(dy == Approx(f.inward ? 0.20672 : 0.13154).margin(1e-5));
    for (const bool paper : {false, true}) {
      TaskTempDir dir;
      const auto file = paper ? edited_yaml(dir, f.id, {{"variant", "paper"}}) : std::string();
      auto env = make_env(f.id, 1, 1, 1, file);
      env->reset();
      set_hinges(*env, 0, 0.3, 0.7);
      const auto& o = observe(*env, 0);
      tips_to(*env, 0, 0, {o[422], o[423], o[424]});
      tips_to(*env, 0, 1, {o[425], o[426], o[427]});
      std::vector<double> terms;
      evaluate(*env, 0, terms);
      const double goal = terms[env->spec().term_index("goal")];
      if (paper)
        CHECK(goal == Approx(f.open_task ? 2 * dist : 2 * (1 - dist)).margin(1e-6));
      else
        CHECK(goal == Approx(f.open_task ? 2 * dy : 1 - 2 * dy).margin(1e-6));
    }
  }
}

TEST_CASE("doors: standing still scores more than ending the episode at once",
          "[tasks][handle][reward][exploit]") {
  // Two fixed policies over one episode: "still" (zero actions: no base force, joints at
  // mid-range) and "flee" (both bases pushed away from the door at full force until a hand is
  // too far from its handle and the episode ends). Under the default (the original's constant
  // of 2, 6 in door_close_outward) every step of standing still pays and staying is worth more
  // than ending; under the paper's 0.2 ending the episode at once pays more than staying, the
  // exploit PPO found (bench/results/gpu-references-h100/README.md).
  struct Outcome {
    double ret = 0, min_step = 1e9;
    int steps = 0;
    bool terminated = false;
  };
  auto run = [](const std::string& id, const std::string& file, bool flee) {
    auto env = make_env(id, 1, 1, 1, file);
    env->reset();
    const auto& act = env->spec().act;
    std::vector<float> a(act.dim(), 0.f);
    if (flee) {
      a[act.at("right.base_translation").start] = 1.f;  // +x: away from the door
      a[act.at("left.base_translation").start] = 1.f;
    }
    Outcome out;
    for (int t = 0; t < env->task().episode_length(); ++t) {
      env->step(a);
      out.ret += env->reward[0];
      out.min_step = std::min(out.min_step, double(env->reward[0]));
      ++out.steps;
      REQUIRE(env->fault[0] == 0);
      if (env->terminated[0] || env->truncated[0]) {
        out.terminated = env->terminated[0];
        break;
      }
    }
    return out;
  };
  for (const auto& f : kDoors) {
    TaskTempDir dir;
    const auto paper_file = edited_yaml(dir, f.id, {{"variant", "paper"}});
    const Outcome still = run(f.id, "", false), flee = run(f.id, "", true);
    const Outcome still_p = run(f.id, paper_file, false), flee_p = run(f.id, paper_file, true);
    INFO(f.id << ": default still " << still.ret << " (" << still.steps << " steps, worst step "
              << still.min_step << "), flee " << flee.ret << " (" << flee.steps
              << " steps); paper still " << still_p.ret << ", flee " << flee_p.ret << " ("
              << flee_p.steps << " steps)");
    // standing still lasts the whole episode; fleeing ends it early
    CHECK_FALSE(still.terminated);
    CHECK(still.steps == 250);
    CHECK(flee.terminated);
    CHECK(flee.steps < 100);
    // the default: every step of standing still pays, so staying beats ending at any step
    CHECK(still.min_step > 0);
    CHECK(still.ret > flee.ret);
    // the paper's formula: ending at once pays more than staying (why it is not the default)
    CHECK(still_p.ret < 0);
    CHECK(flee_p.ret > still_p.ret);
  }
}

// ---- oracles: the object in its goal state ------------------------------------------------

TEST_CASE("lift_underarm oracle: the pot at the goal fires success", "[tasks][handle][oracle]") {
  auto env = make_env("lift_underarm", 1, 1, 1);
  env->reset();
  const auto& sp = env->spec();
  std::vector<double> terms;
  // at the start: no success, goal term 3 (0.985 - 0.4)
  CHECK_FALSE(evaluate(*env, 0, terms));
  CHECK_FALSE(env->slot(0).task->success);
  CHECK(terms[sp.term_index("goal")] == Approx(3 * (0.985 - 0.4)).margin(1e-9));
  // pot lifted 0.4 m to the goal, both hands lifted with it (their bases' z slides)
  place_object(*env, 0, "pot", {0, -0.6, 0.85}, {1, 0, 0, 0});
  mjData* d = env->batch().data(0);
  for (const auto& h : env->model().hands()) d->qpos[h.base_qpos_adr + 2] += 0.4;
  sync(*env, 0);
  CHECK_FALSE(evaluate(*env, 0, terms));  // the palms are still at their handles
  CHECK(env->slot(0).task->success);
  CHECK(terms[sp.term_index("goal")] == Approx(3 * 0.985).margin(1e-9));  // its best value
  CHECK(-terms[sp.term_index("right_hand")] < 0.2);
  CHECK(-terms[sp.term_index("left_hand")] < 0.2);
  // 6 cm off the goal is not a success
  env->reset();
  place_object(*env, 0, "pot", {0, -0.6, 0.79}, {1, 0, 0, 0});
  sync(*env, 0);
  evaluate(*env, 0, terms);
  CHECK_FALSE(env->slot(0).task->success);
}

TEST_CASE("door oracles: the leaves driven to their goal angle fire success",
          "[tasks][handle][oracle]") {
  for (const auto& f : kDoors) {
    for (const bool paper : {false, true}) {
      INFO(f.id << (paper ? ", reward.variant paper" : ", default with the goal gate off"));
      // the hands stay at their mounts: the default's gate is opened by setting it to 0
      TaskTempDir dir;
      const auto file =
          edited_yaml(dir, f.id, {{"variant", paper ? "paper" : "original"}, {"goal_gate", "0"}});
      auto env = make_env(f.id, 1, 1, 1, file);
      env->reset();
      const auto& sp = env->spec();
      const double goal_q = f.open_task ? M_PI / 2 : 0, away_q = M_PI / 2 - goal_q;
      std::vector<double> terms;
      // the start state: no success
      evaluate(*env, 0, terms);
      CHECK_FALSE(env->slot(0).task->success);
      // the opposite angle: no success
      set_hinges(*env, 0, away_q, away_q);
      evaluate(*env, 0, terms);
      CHECK_FALSE(env->slot(0).task->success);
      // one leaf alone: not enough to open (the gap stays under 0.5 m); enough to close, as in
      // the original (the closed leaf's handle and the open one's are 0.41-0.49 m apart in y)
      set_hinges(*env, 0, goal_q, away_q);
      evaluate(*env, 0, terms);
      CHECK(env->slot(0).task->success == !f.open_task);
      env->slot(0).task->success = false;
      // the goal term over the joint range peaks at the goal angle (closing: within 0.01 of its
      // peak, which an outward leaf reaches at about 0.1 rad, where the handles, standing 4 cm in
      // front of the hinges, come closest)
      double best = -1e9, at_goal = 0;
      for (int i = 0; i <= 20; ++i) {
        const double q = M_PI / 2 * i / 20;
        set_hinges(*env, 0, q, q);
        evaluate(*env, 0, terms);
        best = std::max(best, terms[sp.term_index("goal")]);
      }
      set_hinges(*env, 0, goal_q, goal_q);
      evaluate(*env, 0, terms);
      at_goal = terms[sp.term_index("goal")];
      if (f.open_task) {
        CHECK(at_goal == Approx(best).margin(1e-12));
      } else {
        // handles 6 cm apart: the paper's 2 (1 - 0.06), the original's 1 - 2 x 0.06
        CHECK(at_goal == Approx(paper ? 2 * (1 - 0.06) : 1 - 2 * 0.06).margin(1e-9));
        CHECK(at_goal >= best - 0.01);
      }
      CHECK(env->slot(0).task->success);
      // the handle gap at the goal angle
      const auto o = observe(*env, 0);
      const double gap = std::abs(o[423] - o[426]);
      if (f.open_task) CHECK(gap > 0.5);
      else CHECK(gap < 0.5);
    }
  }
}

TEST_CASE("door_open_outward: both hands pushed towards the door open it to success",
          "[tasks][handle][oracle]") {
  // joint targets mid-range, both bases pushed along -x (towards the door) at full force
  // (833 N: 0.28 m/s against the base damping, as in the original): the leaves swing out to
  // their stop and the episode succeeds, within 150 steps (2.5 s)
  auto env = make_env("door_open_outward", 1, 1, 1);
  env->reset();
  const auto& act = env->spec().act;
  std::vector<float> a(act.dim(), 0.f);
  a[act.at("right.base_translation").start] = -1.f;
  a[act.at("left.base_translation").start] = -1.f;
  const auto& task = handle_task(*env);
  bool success = false;
  int steps = 0;
  double qr = 0, ql = 0;
  for (; steps < 150 && !success; ++steps) {
    env->step(a);
    REQUIRE_FALSE(env->terminated[0]);
    success = env->success[0];
    const mjData* d = env->batch().data(0);
    qr = d->qpos[task.hinge_qpos(0)];
    ql = d->qpos[task.hinge_qpos(1)];
  }
  INFO("steps " << steps << ", hinges " << qr << ", " << ql);
  CHECK(success);
  CHECK(qr > 1.0);
  CHECK(ql > 1.0);
}

// ---- resets -------------------------------------------------------------------------------

TEST_CASE("handle tasks: reset states do not terminate and are the start states",
          "[tasks][handle][reset]") {
  for (const char* id : kIds) {
    INFO(id);
    TaskTempDir dir;
    // short episodes so that every slot resets inside step several times
    const auto file = edited_yaml(dir, id, {{"episode_length", "4"}});
    auto env = make_env(id, 6, 11, 1, file);
    env->reset();
    const auto& task = handle_task(*env);
    const bool door = task.params().kind == tasks::HandleParams::Kind::kDoor;
    double start_q = 0;
    for (const auto& f : kDoors)
      if (f.id == std::string(id)) start_q = f.start;
    auto check_start = [&](int s) {
      mjData* d = env->batch().data(s);
      if (door) {
        for (int h = 0; h < 2; ++h) {
          CHECK(d->qpos[task.hinge_qpos(h)] == Approx(start_q).margin(1e-12));
          CHECK(d->qvel[task.hinge_dof(h)] == 0.0);
        }
      } else {
        const auto& o = object_of(*env, "pot");
        CHECK(d->qpos[o.qpos_adr + 0] == Approx(0).margin(1e-12));
        CHECK(d->qpos[o.qpos_adr + 1] == Approx(-0.6).margin(1e-12));
        CHECK(d->qpos[o.qpos_adr + 2] == Approx(0.45).margin(1e-12));
        CHECK(d->qpos[o.qpos_adr + 3] == Approx(1).margin(1e-12));
        for (int k = 0; k < 6; ++k) CHECK(d->qvel[o.dof_adr + k] == 0.0);
      }
      for (const auto& h : env->model().hands())
        for (int k = 0; k < 3; ++k) CHECK(d->qpos[h.base_qpos_adr + k] == 0.0);
      std::vector<double> terms;
      CHECK_FALSE(evaluate(*env, s, terms));
      CHECK_FALSE(env->slot(s).task->success);
    };
    for (int s = 0; s < 6; ++s) check_start(s);
    std::mt19937_64 rng(9);
    std::vector<float> a(static_cast<size_t>(6) * 52);
    int resets = 0;
    for (int step = 0; step < 13; ++step) {
      random_actions(a, rng);
      env->step(a);
      for (int s = 0; s < 6; ++s)
        if (env->terminated[s] || env->truncated[s]) {
          ++resets;
          CHECK(env->fault[s] == 0);
          check_start(s);
        }
    }
    CHECK(resets >= 18);
  }
}

// ---- random actions -----------------------------------------------------------------------

TEST_CASE("handle tasks: random actions at 3 and 16 slots keep everything finite",
          "[tasks][handle][smoke]") {
  for (const char* id : kIds) {
    for (int n : {3, 16}) {
      INFO(id << " with " << n << " slots");
      auto env = make_env(id, n, 4);
      env->reset();
      std::mt19937_64 rng(21);
      std::vector<float> a(static_cast<size_t>(n) * 52);
      int64_t bad = 0, faults = 0;
      for (int step = 0; step < 40; ++step) {
        random_actions(a, rng);
        env->step(a);
        for (float x : env->obs) bad += !std::isfinite(x);
        for (float x : env->reward) bad += !std::isfinite(x);
        for (float x : env->terms) bad += !std::isfinite(x);
        faults += env->take_stats().faults;
      }
      CHECK(bad == 0);
      CHECK(faults == 0);
    }
  }
}

TEST_CASE("handle tasks: same seed, same trajectory for 1 and 2 threads",
          "[tasks][handle][determinism]") {
  for (const char* id : kIds) {
    INFO(id);
    std::vector<std::vector<float>> runs;
    for (int threads : {1, 2}) {
      auto env = make_env(id, 4, 99, threads);
      env->reset();
      std::mt19937_64 rng(3);
      std::vector<float> a(static_cast<size_t>(4) * 52), trace;
      for (int step = 0; step < 25; ++step) {
        random_actions(a, rng);
        env->step(a);
        trace.insert(trace.end(), env->obs.begin(), env->obs.end());
        trace.insert(trace.end(), env->reward.begin(), env->reward.end());
        trace.insert(trace.end(), env->terms.begin(), env->terms.end());
      }
      runs.push_back(std::move(trace));
    }
    REQUIRE(runs[0].size() == runs[1].size());
    CHECK(std::memcmp(runs[0].data(), runs[1].data(), runs[0].size() * sizeof(float)) == 0);
  }
}

// ---- bad YAML -----------------------------------------------------------------------------

TEST_CASE("handle tasks: bad YAML is a ConfigError naming file, key, expected, actual",
          "[tasks][handle][config]") {
  struct Case {
    const char* task;
    std::vector<std::pair<std::string, std::string>> set;  // key, value (empty: remove)
    std::string append;
    const char* key;
    const char* expected;
    const char* actual;
  };
  const std::vector<Case> cases = {
      {"door_open_outward", {}, "colour: red\n", "colour", "one of the keys {",
       "unknown key 'colour'"},
      {"lift_underarm", {{"goal", "[0, -0.6, 0.85]\n  lid: true"}}, "", "pot.lid", "goal",
       "unknown key 'lid'"},
      {"door_close_inward", {{"damping", ""}}, "", "door.damping", "a value for the required key",
       "none"},
      {"door_open_inward", {{"start_angle", "wide"}}, "", "door.start_angle", "", "wide"},
      {"door_close_outward", {{"start_angle", "2.0"}}, "", "door.start_angle",
       "an angle in [0, pi/2] rad", "2.0"},
      {"door_open_outward", {{"swing", "sideways"}}, "", "door.swing", "'inward' or 'outward'",
       "sideways"},
      {"lift_underarm", {{"mass", "-1"}}, "", "pot.mass", "a mass in [0.01, 100] kg", "-1"},
      {"lift_underarm", {{"hand_point", "elbow"}}, "", "reward.hand_point",
       "'palm' or 'fingertips'", "elbow"},
      {"door_open_inward", {{"when", "sometimes"}}, "", "success.when", "'wider' or 'narrower'",
       "sometimes"},
      {"lift_underarm", {{"episode_length", "0"}}, "", "episode_length", "an episode length > 0",
       "0"},
      // reward variants (tasks/README.md)
      {"door_close_outward", {{"variant", "both"}}, "", "reward.variant", "'original' or 'paper'",
       "both"},
      {"door_open_inward", {{"paper", "{constant: 0.2, colour: red}"}}, "", "reward.paper.colour",
       "a key of 'reward'", "'colour'"},
      {"door_close_inward", {{"paper", "{constant: 5000}"}}, "", "reward.paper.constant",
       "a constant in [-1000, 1000]", "5000"},
      {"door_open_outward", {{"target", "diagonal"}}, "", "reward.target",
       "'y_gap' or 'distance'", "diagonal"},
      {"lift_underarm", {{"original", ""}}, "", "reward", "a map of the other variant's values",
       "neither"},
  };
  for (const auto& c : cases) {
    INFO(c.task << ": " << c.key);
    TaskTempDir dir;
    std::string text = default_yaml(c.task);
    for (auto& [k, v] : c.set) text = v.empty() ? remove_key(text, k) : set_value(text, k, v);
    text += c.append;
    const std::string file = dir.write("bad.yaml", text);
    const auto e = thrown<ConfigError>([&] { tasks::make_task(c.task, file); });
    const std::string what = e.what();
    INFO("what(): " << what);
    CHECK(contains(e.file(), file));
    CHECK(contains(what, file));
    CHECK(e.key() == c.key);
    CHECK(contains(what, c.key));
    CHECK(contains(e.expected(), c.expected));
    CHECK(contains(e.actual(), c.actual));
    CHECK(contains(what, e.actual()));
  }
}

// ---- soak ---------------------------------------------------------------------------------
// tests/tasks/task_fixture.h soak_task, on episodes cut to 60 steps so that every slot resets
// inside step
TEST_CASE("soak: lift_underarm: 50k random slot-steps without a fault",
          "[tasks][soak][handle_soak]") {
  soak_task("lift_underarm", 60);
}
TEST_CASE("soak: door_open_outward: 50k random slot-steps without a fault",
          "[tasks][soak][handle_soak]") {
  soak_task("door_open_outward", 60);
}
TEST_CASE("soak: door_close_inward: 50k random slot-steps without a fault",
          "[tasks][soak][handle_soak]") {
  soak_task("door_close_inward", 60);
}
TEST_CASE("soak: door_open_inward: 50k random slot-steps without a fault",
          "[tasks][soak][handle_soak]") {
  soak_task("door_open_inward", 60);
}
TEST_CASE("soak: door_close_outward: 50k random slot-steps without a fault",
          "[tasks][soak][handle_soak]") {
  soak_task("door_close_outward", 60);
}
