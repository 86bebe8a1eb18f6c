// The table family (swing_cup, scissors, pen, switch, pour_water): layouts against the paper's
// index tables, every reward term against values worked out here from the README's geometry on
// crafted states, an oracle per task (the object driven into its goal state fires success and
// the goal term's best value; the opposite state does not), resets, random-action rollouts,
// determinism, strict YAML errors and a 50k slot-step soak per task.
#include <chrono>
#include <cstring>
#include <functional>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "tasks/table_family.h"
#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

namespace {

const std::vector<std::string> kIds = {"swing_cup", "scissors", "pen", "switch", "pour_water"};

// ---- independent geometry (README numbers, not the code's constants) ----------------------

std::array<double, 3> frame_point(const mjData* d, int body, std::array<double, 3> local) {
  std::array<double, 3> out{};
  mju_rotVecQuat(out.data(), local.data(), d->xquat + 4 * body);
  for (int k = 0; k < 3; ++k) out[k] += d->xpos[3 * body + k];
  return out;
}

double dist(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
}

// hand 0 right, 1 left: sum over the 5 fingertips (distal origin + 0.02 m along local z)
double tip_sum(const tasks::TaskEnv& env, const mjData* d, int hand,
               const std::array<double, 3>& p) {
  double s = 0;
  for (int b : env.model().hands()[hand].tip_bodies) s += dist(frame_point(d, b, {0, 0, 0.02}), p);
  return s;
}

std::array<double, 3> tip_centroid(const tasks::TaskEnv& env, const mjData* d, int hand) {
  std::array<double, 3> c{};
  for (int b : env.model().hands()[hand].tip_bodies) {
    auto t = frame_point(d, b, {0, 0, 0.02});
    for (int k = 0; k < 3; ++k) c[k] += t[k] / 5;
  }
  return c;
}

// Moves a free-base hand (slides along the world axes) so its fingertip centroid is at p.
void hand_to(tasks::TaskEnv& env, int s, int hand, const std::array<double, 3>& p) {
  mjData* d = env.batch().data(s);
  const auto c = tip_centroid(env, d, hand);
  const int adr = env.model().hands()[hand].base_qpos_adr;
  for (int k = 0; k < 3; ++k) d->qpos[adr + k] += p[k] - c[k];
  sync(env, s);
}

int joint_qpos(const tasks::TaskEnv& env, const char* name) {
  const int j = mj_name2id(env.model().mj(), mjOBJ_JOINT, name);
  REQUIRE(j >= 0);
  return env.model().mj()->jnt_qposadr[j];
}

// The two reward points of each task (right hand's, left hand's), from the README's geometry.
std::pair<std::array<double, 3>, std::array<double, 3>> points(const tasks::TaskEnv& env,
                                                               const std::string& id,
                                                               const mjData* d) {
  if (id == "swing_cup") {
    const int b = body_id(env, "cup");
    return {frame_point(d, b, {0.075, 0, 0.07}), frame_point(d, b, {-0.075, 0, 0.07})};
  }
  if (id == "scissors")
    return {frame_point(d, body_id(env, "scissors_moving"), {0.15, 0.045, 0}),
            frame_point(d, body_id(env, "scissors"), {0.15, -0.045, 0})};
  if (id == "pen")
    return {frame_point(d, body_id(env, "pen_cap"), {0.06, 0, 0}),
            frame_point(d, body_id(env, "pen"), {-0.09, 0, 0})};
  if (id == "switch")
    return {frame_point(d, body_id(env, "switch1_rocker"), {0.04, 0, 0.008}),
            frame_point(d, body_id(env, "switch2_rocker"), {0.04, 0, 0.008})};
  return {frame_point(d, body_id(env, "kettle"), {0.15, 0, 0.08}),
          frame_point(d, body_id(env, "bucket"), {0, 0, 0.15})};
}

double term(const tasks::TaskEnv& env, const std::vector<double>& terms, const std::string& n) {
  const int i = env.spec().term_index(n);
  INFO("term " << n);
  REQUIRE(i >= 0);
  return terms[static_cast<size_t>(i)];
}

// The goal term's name and its value from the README's formula, given the task state.
struct GoalCheck {
  std::string name;
  double value;
};

// Switch press-point distance to its pressed position, from the README: rocker hinge 0.12 m
// above the switch origin, tilted -0.27925 rad about y at angle 0, pressed at 0.5585 rad.
double press_distance(const tasks::TaskEnv& env, const mjData* d, const char* sw) {
  const int root = body_id(env, sw);
  const int rocker = body_id(env, std::string(sw) + "_rocker");
  const double a = 0.5585 - 0.27925;
  const Q q = qmul(Q{d->xquat[4 * root], d->xquat[4 * root + 1], d->xquat[4 * root + 2],
                     d->xquat[4 * root + 3]},
                   qaxis(0, 1, 0, a));
  std::array<double, 3> hinge{}, h{0, 0, 0.12}, press{0.04, 0, 0.008}, p{};
  mju_rotVecQuat(hinge.data(), h.data(), d->xquat + 4 * root);
  for (int k = 0; k < 3; ++k) hinge[k] += d->xpos[3 * root + k];
  mju_rotVecQuat(p.data(), press.data(), q.data());
  for (int k = 0; k < 3; ++k) p[k] += hinge[k];
  return dist(frame_point(d, rocker, {0.04, 0, 0.008}), p);
}

GoalCheck expected_goal(tasks::TaskEnv& env, const std::string& id, int s, double sr, double sl) {
  const mjData* d = env.batch().data(s);
  if (id == "swing_cup") {
    const int b = body_id(env, "cup");
    const Q cup{d->xquat[4 * b], d->xquat[4 * b + 1], d->xquat[4 * b + 2], d->xquat[4 * b + 3]};
    const Q e = qmul(cup, qconj(qaxis(0, 0, 1, 1.5 * M_PI)));
    const double th = 2 * std::asin(std::min(1.0, std::sqrt(e[1] * e[1] + e[2] * e[2] + e[3] * e[3])));
    return {"rotation", sr < 0.4 && sl < 0.4 ? 5 / (th + 0.1) - 1 : 0.0};
  }
  if (id == "scissors") {
    const double q = d->qpos[joint_qpos(env, "scissors_hinge")];
    return {"opening", sr < 0.7 && sl < 0.7 ? 5 * (0.59 - std::abs(q)) : 0.0};
  }
  if (id == "pen") {
    auto [r, l] = points(env, id, d);
    return {"separation", sr < 0.75 && sl < 0.75 ? 5 * dist(r, l) - 0.8 : 0.0};
  }
  if (id == "switch") {
    // the default variant: the original's zero point, both switches off (README)
    const double dd = press_distance(env, d, "switch1") + press_distance(env, d, "switch2");
    return {"press", 50 * (0.045 - dd)};
  }
  const auto spout = frame_point(d, body_id(env, "kettle"), {-0.2, 0, 0.13});
  auto [r, l] = points(env, id, d);
  // the default (version 2, bidex's reward): a slope of 10 (README, "Reward")
  return {"pour", sr < 0.7 && sl < 0.7 ? 10 * (0.5 - dist(spout, l)) : 0.0};
}

// Every term of slot s against the hand-worked values.
void check_terms(tasks::TaskEnv& env, const std::string& id, int s) {
  const mjData* d = env.batch().data(s);
  auto [r, l] = points(env, id, d);
  const double sr = tip_sum(env, d, 0, r), sl = tip_sum(env, d, 1, l);
  std::vector<double> terms;
  evaluate(env, s, terms);
  INFO("task " << id << ": sums " << sr << ", " << sl);
  if (id == "pen") {  // the default: exp(-10 x the mean of the five distances)
    CHECK(term(env, terms, "reach_right") == Approx(std::exp(-10 * sr / 5)).epsilon(1e-9));
    CHECK(term(env, terms, "reach_left") == Approx(std::exp(-10 * sl / 5)).epsilon(1e-9));
  } else {
    CHECK(term(env, terms, "reach_right") == Approx(-sr).epsilon(1e-9));
    CHECK(term(env, terms, "reach_left") == Approx(-sl).epsilon(1e-9));
  }
  const std::map<std::string, double> offsets = {{"scissors", 2}, {"switch", 2}, {"pour_water", 1}};
  if (offsets.count(id)) CHECK(term(env, terms, "offset") == offsets.at(id));
  if (id == "pour_water") {  // the default: 20 min(rise, 0.05) while the gate is open
    const double rise = d->qpos[object_of(env, "kettle").qpos_adr + 2] - 0.4;
    const double lift = sr < 0.7 && sl < 0.7 ? 20 * std::min(std::max(rise, 0.0), 0.05) : 0.0;
    CHECK(term(env, terms, "lift") == Approx(lift).margin(1e-9));
  }
  const GoalCheck g = expected_goal(env, id, s, sr, sl);
  CHECK(term(env, terms, g.name) == Approx(g.value).margin(1e-9));
}

// ---- oracle states ------------------------------------------------------------------------

// Drives the object of slot s into its goal state (goal=true) or the opposite (goal=false),
// bypassing the hands, and syncs.
void object_state(tasks::TaskEnv& env, const std::string& id, int s, bool goal) {
  mjData* d = env.batch().data(s);
  if (id == "swing_cup") {
    const auto& o = object_of(env, "cup");
    const Q q = qaxis(0, 0, 1, goal ? 1.5 * M_PI : 0.5 * M_PI);
    for (int k = 0; k < 4; ++k) d->qpos[o.qpos_adr + 3 + k] = q[k];
  } else if (id == "scissors") {
    d->qpos[joint_qpos(env, "scissors_hinge")] = goal ? 0.0 : -0.59;
  } else if (id == "pen") {
    d->qpos[joint_qpos(env, "pen_slide")] = goal ? 0.492 : 0.0;
  } else if (id == "switch") {
    d->qpos[joint_qpos(env, "switch1_hinge")] = goal ? 0.5585 : 0.0;
    d->qpos[joint_qpos(env, "switch2_hinge")] = goal ? 0.5585 : 0.0;
  } else {
    if (goal) {
      // translate the kettle so its spout tip (-0.2, 0, 0.13) is at the bucket's opening
      sync(env, s);
      const auto spout = frame_point(d, body_id(env, "kettle"), {-0.2, 0, 0.13});
      const auto open = frame_point(d, body_id(env, "bucket"), {0, 0, 0.15});
      const auto& o = object_of(env, "kettle");
      for (int k = 0; k < 3; ++k) d->qpos[o.qpos_adr + k] += open[k] - spout[k];
    }
  }
  sync(env, s);
}

// The goal term's best value (README).
double best_goal(const std::string& id) {
  if (id == "swing_cup") return 5 / 0.1 - 1;
  if (id == "scissors") return 5 * 0.59;
  if (id == "pen") return 5 * (0.18 + 0.492) - 0.8;
  if (id == "switch") return 50 * 0.045;
  return 10 * 0.5;  // pour_water (version 2: pour_scale 10)
}

const char* goal_term(const std::string& id) {
  if (id == "swing_cup") return "rotation";
  if (id == "scissors") return "opening";
  if (id == "pen") return "separation";
  if (id == "switch") return "press";
  return "pour";
}

}  // namespace

// ---- layouts ------------------------------------------------------------------------------

TEST_CASE("table family layouts are the paper's index tables", "[tasks][table][layout]") {
  struct Tail {
    const char* id;
    const char* p1;
    const char* p2;
    int episode;
    std::vector<const char*> terms;
  };
  const std::vector<Tail> tails = {
      {"swing_cup", "handle.right", "handle.left", 300, {"reach_right", "reach_left", "rotation"}},
      {"scissors", "handle.right", "handle.left", 150,
       {"offset", "reach_right", "reach_left", "opening"}},
      {"pen", "pen.body", "pen.cap", 125, {"reach_right", "reach_left", "separation"}},
      {"switch", "switch1.pos", "switch2.pos", 125, {"offset", "reach_right", "reach_left", "press"}},
      {"pour_water", "kettle.handle", "bucket.pos", 125,
       {"offset", "reach_right", "reach_left", "lift", "pour"}},
  };
  const auto& ref = tasks::find_task("catch_underarm").spec();  // the free-base hand blocks
  for (const auto& t : tails) {
    INFO("task " << t.id);
    const auto& sp = tasks::find_task(t.id).spec();
    CHECK(sp.obs.dim() == 428);
    CHECK(sp.act.dim() == 52);
    CHECK(sp.free_base);
    CHECK(sp.episode_length == t.episode);
    // the hand blocks (0-397) and the actions are catch_underarm's, slice for slice
    for (size_t i = 0; i < ref.obs.slices().size(); ++i) {
      const auto& a = ref.obs.slices()[i];
      if (a.start >= 398) break;
      REQUIRE(i < sp.obs.slices().size());
      CHECK(sp.obs.slices()[i].name == a.name);
      CHECK(sp.obs.slices()[i].start == a.start);
      CHECK(sp.obs.slices()[i].size == a.size);
    }
    REQUIRE(sp.act.slices().size() == ref.act.slices().size());
    for (size_t i = 0; i < ref.act.slices().size(); ++i) {
      CHECK(sp.act.slices()[i].name == ref.act.slices()[i].name);
      CHECK(sp.act.slices()[i].start == ref.act.slices()[i].start);
      CHECK(sp.act.slices()[i].size == ref.act.slices()[i].size);
    }
    CHECK(sp.act.at("right.base_translation").start == 20);
    CHECK(sp.act.at("left.base_rotation").start == 49);
    // the paper's tail: 398-404 pose, 405-407, 408-410, 411-417 goal, 418-421, 422-424, 425-427
    const std::vector<std::tuple<std::string, int, int, bool>> rows = {
        {"object.pose", 398, 7, false}, {"object.linvel", 405, 3, false},
        {"object.angvel", 408, 3, false}, {"goal.pose", 411, 7, true},
        {"goal.rot_diff", 418, 4, true}, {t.p1, 422, 3, false}, {t.p2, 425, 3, false}};
    for (auto& [name, start, size, goal] : rows) {
      INFO("slice " << name);
      const auto* s = sp.obs.find(name);
      REQUIRE(s != nullptr);
      CHECK(s->start == start);
      CHECK(s->size == size);
      CHECK(s->goal == goal);
    }
    std::vector<std::string> names;
    for (auto& x : sp.reward_terms) names.push_back(x.name);
    CHECK(names == std::vector<std::string>(t.terms.begin(), t.terms.end()));
    REQUIRE(sp.agents.size() == 2);
    auto env = make_env(t.id, 1);
    CHECK(env->obs_dim() == 428);
    CHECK(env->act_dim() == 52);
  }
}

TEST_CASE("table family tail observations hold the object, the goal and the two points",
          "[tasks][table][layout][obs]") {
  for (const auto& id : kIds) {
    INFO("task " << id);
    auto env = make_env(id, 1);
    const mjData* d = env->batch().data(0);
    auto o = observe(*env, 0);
    auto [r, l] = points(*env, id, d);
    const auto& sp = env->spec();
    const auto p1 = sp.obs.slices()[sp.obs.slices().size() - 2];
    const auto p2 = sp.obs.slices().back();
    // the pen lists its body point (the left hand's) first, as the paper
    const auto& first = id == "pen" ? l : r;
    const auto& second = id == "pen" ? r : l;
    for (int k = 0; k < 3; ++k) {
      CHECK(o[p1.start + k] == Approx(first[k]).margin(1e-6));
      CHECK(o[p2.start + k] == Approx(second[k]).margin(1e-6));
    }
    const char* obj = id == "swing_cup" ? "cup" : id == "scissors" ? "scissors" : id == "pen" ? "pen"
                      : id == "switch" ? "switch1_rocker" : "kettle";
    const int b = body_id(*env, obj);
    for (int k = 0; k < 3; ++k) CHECK(o[398 + k] == Approx(d->xpos[3 * b + k]).margin(1e-6));
    CHECK(o[398 + 6] == Approx(d->xquat[4 * b]).margin(1e-6));  // w last
    // the goal's rotation difference is a unit quaternion
    double n = 0;
    for (int k = 0; k < 4; ++k) n += double(o[418 + k]) * o[418 + k];
    CHECK(n == Approx(1).margin(1e-5));
  }
}

// ---- reward terms -------------------------------------------------------------------------

TEST_CASE("table family reward terms match hand-worked values on crafted states",
          "[tasks][table][reward]") {
  for (const auto& id : kIds) {
    auto env = make_env(id, 1);
    SECTION(id + ": hands at their mounts, object at its start") { check_terms(*env, id, 0); }
    SECTION(id + ": hands at the points (gate open), object at its start") {
      auto [r, l] = points(*env, id, env->batch().data(0));
      hand_to(*env, 0, 0, r);
      hand_to(*env, 0, 1, l);
      check_terms(*env, id, 0);
    }
    SECTION(id + ": hands at the points, object in its goal state") {
      object_state(*env, id, 0, true);
      auto [r, l] = points(*env, id, env->batch().data(0));
      hand_to(*env, 0, 0, r);
      hand_to(*env, 0, 1, l);
      check_terms(*env, id, 0);
    }
    SECTION(id + ": only the right hand at its point") {
      auto [r, l] = points(*env, id, env->batch().data(0));
      hand_to(*env, 0, 0, r);
      check_terms(*env, id, 0);
    }
  }
}

TEST_CASE("oracle: each table task's goal state fires success and the goal term's best value",
          "[tasks][table][oracle]") {
  for (const auto& id : kIds) {
    INFO("task " << id);
    auto env = make_env(id, 2);
    // slot 0: the goal state with the hands at the points (gates open); slot 1: the opposite
    object_state(*env, id, 0, true);
    object_state(*env, id, 1, false);
    for (int s = 0; s < 2; ++s) {
      auto [r, l] = points(*env, id, env->batch().data(s));
      hand_to(*env, s, 0, r);
      hand_to(*env, s, 1, l);
    }
    std::vector<double> terms;
    const bool end0 = evaluate(*env, 0, terms);
    CHECK(env->slot_state(0).success);
    CHECK_FALSE(end0);
    CHECK(term(*env, terms, goal_term(id)) == Approx(best_goal(id)).margin(1e-6));
    const double best = terms[static_cast<size_t>(env->spec().term_index(goal_term(id)))];
    evaluate(*env, 1, terms);
    CHECK_FALSE(env->slot_state(1).success);
    CHECK(term(*env, terms, goal_term(id)) < best - 0.1);
  }
}

TEST_CASE("switch: the original's zero point by default, the paper's 1.4 as a variant",
          "[tasks][table][reward]") {
  // press = 50 (press_offset - d), d the summed distance of the press points to their pressed
  // positions: 0.044975 m with both switches off, 0 with both on (README)
  TaskTempDir dir;
  const auto paper_file = edited_yaml(dir, "switch", {{"variant", "paper"}});
  for (const bool paper : {false, true}) {
    INFO((paper ? "reward.variant paper" : "default (original)"));
    auto env = make_env("switch", 2, 1, 1, paper ? paper_file : std::string());
    const auto& tp = dynamic_cast<const tasks::TableTask&>(env->task()).params();
    CHECK(tp.reward_variant == (paper ? "paper" : "original"));
    const double offset = paper ? 1.4 : 0.045;
    object_state(*env, "switch", 0, false);
    object_state(*env, "switch", 1, true);
    std::vector<double> terms;
    evaluate(*env, 0, terms);
    const double off = term(*env, terms, "press");
    CHECK(off == Approx(50 * (offset - 0.044975)).margin(1e-4));
    CHECK(term(*env, terms, "offset") == 2);
    evaluate(*env, 1, terms);
    const double on = term(*env, terms, "press");
    CHECK(on == Approx(50 * offset).margin(1e-9));
    // the same signal (2.25 from off to on); the default's zero point leaves no constant of
    // 67.75 a step (the paper's) for the return to carry
    CHECK(on - off == Approx(50 * 0.044975).margin(1e-4));
    if (!paper) CHECK(std::abs(off) < 0.01);
  }
}

TEST_CASE("pen: the paper's one distance a hand by default, the original's sums as a variant",
          "[tasks][table][reward]") {
  // reach = exp(-10 d): d the mean of the five fingertip points' distances (default, the paper's
  // one distance a hand), or their sum (reward.variant original, the original code's). At the
  // start the sums are about 1.1 m: the original's pays about 2e-5 a step, the default about
  // 0.1 (README, "Reward")
  TaskTempDir dir;
  const auto original_file = edited_yaml(dir, "pen", {{"variant", "original"}});
  for (const bool original : {false, true}) {
    INFO((original ? "reward.variant original" : "default (paper)"));
    auto env = make_env("pen", 1, 1, 1, original ? original_file : std::string());
    const auto& tp = dynamic_cast<const tasks::TableTask&>(env->task()).params();
    CHECK(tp.reward_variant == (original ? "original" : "paper"));
    const mjData* d = env->batch().data(0);
    auto [r, l] = points(*env, "pen", d);
    const double sr = tip_sum(*env, d, 0, r), sl = tip_sum(*env, d, 1, l);
    CHECK(sr == Approx(1.1).margin(0.15));
    CHECK(sl == Approx(1.1).margin(0.15));
    std::vector<double> terms;
    evaluate(*env, 0, terms);
    const double scale = original ? 10 : 2;
    const double right = term(*env, terms, "reach_right"), left = term(*env, terms, "reach_left");
    CHECK(right == Approx(std::exp(-scale * sr)).epsilon(1e-9));
    CHECK(left == Approx(std::exp(-scale * sl)).epsilon(1e-9));
    if (original) CHECK(right + left < 1e-4);
    else CHECK(right + left > 0.1);
    // the gate (both sums below 0.75 m) is shut at the start in both
    CHECK(term(*env, terms, "separation") == 0);
  }
}

TEST_CASE("pour_water: the lift term pays for the kettle's rise, capped, while the gate is open",
          "[tasks][table][reward]") {
  // lift = lift_scale min(max(z - 0.4, 0), lift_max), z the kettle's height (its start 0.4 m),
  // while both fingertip sums are below the gate (0.7 m); 20 and 0.05 by default (version 2),
  // off under reward.variant paper (README, "Reward")
  TaskTempDir dir;
  const auto paper = edited_yaml(dir, "pour_water", {{"variant", "paper"}});
  auto raised = [&](tasks::TaskEnv& env, double h, bool hands_at_points) {
    mjData* d = env.batch().data(0);
    d->qpos[object_of(env, "kettle").qpos_adr + 2] = 0.4 + h;
    sync(env, 0);
    if (hands_at_points) {
      auto [r, l] = points(env, "pour_water", d);
      hand_to(env, 0, 0, r);
      hand_to(env, 0, 1, l);
    }
    std::vector<double> terms;
    evaluate(env, 0, terms);
    return term(env, terms, "lift");
  };
  auto env = make_env("pour_water", 1, 1, 1);
  CHECK(dynamic_cast<const tasks::TableTask&>(env->task()).params().lift_scale == 20);
  CHECK(raised(*env, 0.03, true) == Approx(20 * 0.03).epsilon(1e-6));
  CHECK(raised(*env, 0.2, true) == Approx(20 * 0.05).epsilon(1e-9));  // capped at lift_max
  CHECK(raised(*env, 0.0, true) == Approx(0).margin(1e-6));
  auto shut = make_env("pour_water", 1, 1, 1);  // hands at their mounts: the gate shut
  CHECK(raised(*shut, 0.03, false) == 0);
  auto off = make_env("pour_water", 1, 1, 1, paper);  // the printed formula: no lift term
  CHECK(raised(*off, 0.03, true) == 0);
}

TEST_CASE("pour_water: bidex's reward by default, the printed formula as reward.variant paper",
          "[tasks][table][reward]") {
  // pour = pour_scale (0.5 - d), d the spout tip's distance to the bucket opening, while both
  // fingertip sums are below 0.7 m: pour_scale 10 by default (version 2), 2 under variant paper
  // (the printed formula's slope, version 1's default); README, "Reward"
  TaskTempDir dir;
  const auto paper = edited_yaml(dir, "pour_water", {{"variant", "paper"}});
  for (const bool printed : {false, true}) {
    INFO((printed ? "reward.variant paper" : "default (bidex)"));
    auto env = make_env("pour_water", 1, 1, 1, printed ? paper : std::string());
    const auto& tp = dynamic_cast<const tasks::TableTask&>(env->task()).params();
    CHECK(tp.reward_variant == (printed ? "paper" : "bidex"));
    CHECK(tp.goal_scale == (printed ? 2 : 10));  // pour_scale
    CHECK(tp.lift_scale == (printed ? 0 : 20));
    mjData* d = env->batch().data(0);
    auto [r, l] = points(*env, "pour_water", d);
    hand_to(*env, 0, 0, r);  // both hands at their points: the gate open
    hand_to(*env, 0, 1, l);
    const auto spout = frame_point(d, body_id(*env, "kettle"), {-0.2, 0, 0.13});
    const double dd = dist(spout, points(*env, "pour_water", d).second);
    CHECK(dd == Approx(0.1).margin(0.03));  // the spout starts about 0.1 m from the opening
    std::vector<double> terms;
    evaluate(*env, 0, terms);
    CHECK(term(*env, terms, "pour") == Approx((printed ? 2 : 10) * (0.5 - dd)).margin(1e-9));
    CHECK(term(*env, terms, "offset") == 1);
  }
  // the variants pour_water knows: bidex's (its own values) and paper (the map)
  const auto bad = edited_yaml(dir, "pour_water", {{"variant", "original"}}, "bad.yaml");
  const auto e = thrown<ConfigError>([&] { tasks::make_task("pour_water", bad); });
  CHECK(e.key() == "reward.variant");
  CHECK(contains(e.expected(), "'bidex' or 'paper'"));
  CHECK(contains(e.actual(), "original"));
  CHECK(contains(e.what(), bad));
}

TEST_CASE("table family success thresholds sit where the README says", "[tasks][table][oracle]") {
  std::vector<double> terms;
  {  // scissors: q > -0.3
    auto env = make_env("scissors", 2);
    const int a = joint_qpos(*env, "scissors_hinge");
    env->batch().data(0)->qpos[a] = -0.29;
    env->batch().data(1)->qpos[a] = -0.31;
    sync(*env, 0);
    sync(*env, 1);
    evaluate(*env, 0, terms);
    evaluate(*env, 1, terms);
    CHECK(env->slot_state(0).success);
    CHECK_FALSE(env->slot_state(1).success);
  }
  {  // pen: grip points more than 0.3 m apart: slide 0.12 m from 0.18 m
    auto env = make_env("pen", 2);
    const int a = joint_qpos(*env, "pen_slide");
    env->batch().data(0)->qpos[a] = 0.125;
    env->batch().data(1)->qpos[a] = 0.115;
    sync(*env, 0);
    sync(*env, 1);
    evaluate(*env, 0, terms);
    evaluate(*env, 1, terms);
    CHECK(env->slot_state(0).success);
    CHECK_FALSE(env->slot_state(1).success);
  }
  {  // switch: only one switch pressed is not a success
    auto env = make_env("switch", 1);
    env->batch().data(0)->qpos[joint_qpos(*env, "switch1_hinge")] = 0.5585;
    sync(*env, 0);
    evaluate(*env, 0, terms);
    CHECK_FALSE(env->slot_state(0).success);
    CHECK(term(*env, terms, "press") == Approx(50 * (0.045 - 0.022483)).margin(0.001));
  }
  {  // swing_cup: theta < 0.785
    auto env = make_env("swing_cup", 2);
    const auto& o = object_of(*env, "cup");
    const Q in = qaxis(0, 0, 1, 1.5 * M_PI - 0.78), out = qaxis(0, 0, 1, 1.5 * M_PI - 0.79);
    for (int k = 0; k < 4; ++k) {
      env->batch().data(0)->qpos[o.qpos_adr + 3 + k] = in[k];
      env->batch().data(1)->qpos[o.qpos_adr + 3 + k] = out[k];
    }
    sync(*env, 0);
    sync(*env, 1);
    evaluate(*env, 0, terms);
    evaluate(*env, 1, terms);
    CHECK(env->slot_state(0).success);
    CHECK_FALSE(env->slot_state(1).success);
  }
}

TEST_CASE("table family terminations: cup or bucket dropped, hands too far", "[tasks][table][reward]") {
  std::vector<double> terms;
  {
    auto env = make_env("swing_cup", 2);
    const auto& o = object_of(*env, "cup");
    place_object(*env, 0, "cup", {0, 0, 0.301}, qaxis(0, 0, 1, 0.5 * M_PI));
    place_object(*env, 1, "cup", {0, 0, 0.299}, qaxis(0, 0, 1, 0.5 * M_PI));
    (void)o;
    sync(*env, 0);
    sync(*env, 1);
    CHECK_FALSE(evaluate(*env, 0, terms));
    CHECK(evaluate(*env, 1, terms));
  }
  {
    auto env = make_env("pour_water", 2);
    // the bucket's opening is 0.15 m above its origin: 0.2 is the drop height
    place_object(*env, 0, "bucket", {0, -0.3, 0.051}, {1, 0, 0, 0});
    place_object(*env, 1, "bucket", {0, -0.3, 0.049}, {1, 0, 0, 0});
    sync(*env, 0);
    sync(*env, 1);
    CHECK_FALSE(evaluate(*env, 0, terms));
    CHECK(evaluate(*env, 1, terms));
  }
  for (const char* id : {"scissors", "pen"}) {
    INFO("task " << id);
    const double limit = std::string(id) == "scissors" ? 1.75 : 1.5;
    auto env = make_env(id, 2);
    // move the left hand away along +x until its sum passes the limit in slot 1 only
    for (int s = 0; s < 2; ++s) {
      mjData* d = env->batch().data(s);
      auto [r, l] = points(*env, id, d);
      const double now = tip_sum(*env, d, 1, l);
      REQUIRE(now < limit);
      // the sum grows by about 5 per metre once the hand is far: step until it crosses
      const int adr = env->model().hands()[1].base_qpos_adr;
      while (tip_sum(*env, d, 1, l) < limit + (s == 0 ? -0.02 : 0.02)) {
        d->qpos[adr + 2] += 0.001;
        sync(*env, s);
      }
      if (s == 0) {
        d->qpos[adr + 2] -= 0.001;
        sync(*env, s);
      }
    }
    CHECK_FALSE(evaluate(*env, 0, terms));
    CHECK(evaluate(*env, 1, terms));
  }
  {  // switch: no task termination
    auto env = make_env("switch", 1);
    mjData* d = env->batch().data(0);
    d->qpos[env->model().hands()[1].base_qpos_adr + 2] += 3;
    sync(*env, 0);
    CHECK_FALSE(evaluate(*env, 0, terms));
  }
}

// ---- resets -------------------------------------------------------------------------------

TEST_CASE("table family resets restore the object and its joints, the switches included",
          "[tasks][table][reset]") {
  for (const auto& id : kIds) {
    INFO("task " << id);
    const int nslot = 8;
    auto env = make_env(id, nslot, 3);
    std::mt19937_64 rng(5);
    std::vector<float> a(static_cast<size_t>(nslot) * env->act_dim());
    // drive the joints away from their reset values, then reset every slot
    for (int i = 0; i < 20; ++i) {
      random_actions(a, rng);
      env->step(a);
    }
    for (int s = 0; s < nslot; ++s) {
      mjData* d = env->batch().data(s);
      if (id == "switch") {
        d->qpos[joint_qpos(*env, "switch1_hinge")] = 0.5;
        d->qpos[joint_qpos(*env, "switch2_hinge")] = 0.4;
      } else if (id == "scissors") {
        d->qpos[joint_qpos(*env, "scissors_hinge")] = 0.3;
      } else if (id == "pen") {
        d->qpos[joint_qpos(*env, "pen_slide")] = 0.2;
      }
    }
    env->reset();
    const auto p = tasks::load_table_params(tasks::default_task_config(id),
                                            static_cast<const tasks::TableTask&>(env->task()).kind());
    for (int s = 0; s < nslot; ++s) {
      const mjData* d = env->batch().data(s);
      const char* root = id == "swing_cup" ? "cup" : id == "scissors" ? "scissors" : id == "pen" ? "pen"
                         : id == "switch" ? "switch1" : "kettle";
      const int b = body_id(*env, root);
      for (int k = 0; k < 3; ++k) CHECK(d->xpos[3 * b + k] == Approx(p.object.pos[k]).margin(1e-9));
      if (id == "switch") {
        CHECK(d->qpos[joint_qpos(*env, "switch1_hinge")] == 0);
        CHECK(d->qpos[joint_qpos(*env, "switch2_hinge")] == 0);
      } else if (id == "scissors") {
        CHECK(d->qpos[joint_qpos(*env, "scissors_hinge")] == -0.59);
      } else if (id == "pen") {
        CHECK(d->qpos[joint_qpos(*env, "pen_slide")] == 0);
      }
      for (int h = 0; h < 2; ++h) {
        const auto& hi = env->model().hands()[h];
        for (int k = 0; k < 6; ++k) CHECK(d->qvel[hi.base_dof_adr + k] == 0);
      }
      CHECK_FALSE(env->slot_state(s).success);
    }
  }
}

TEST_CASE("pour_water's water starts in the kettle and stays there at rest",
          "[tasks][table][reset]") {
  auto env = make_env("pour_water", 1);
  const int kettle = body_id(*env, "kettle");
  std::vector<float> zero(static_cast<size_t>(env->act_dim()), 0.f);
  for (int i = 0; i < 30; ++i) env->step(zero);
  const mjData* d = env->batch().data(0);
  int inside = 0;
  for (int i = 0; i < 8; ++i) {
    const int b = body_id(*env, "water" + std::to_string(i));
    const double dx = d->xpos[3 * b] - d->xpos[3 * kettle];
    const double dy = d->xpos[3 * b + 1] - d->xpos[3 * kettle + 1];
    const double dz = d->xpos[3 * b + 2] - d->xpos[3 * kettle + 2];
    inside += std::abs(dx) < 0.074 && std::abs(dy) < 0.074 && dz > 0 && dz < 0.14;
  }
  CHECK(inside == 8);
  CHECK(mj_name2id(env->model().mj(), mjOBJ_BODY, "water8") < 0);
  CHECK(env->batch().total_faults() == 0);
}

TEST_CASE("pour_water runs with the original's 30 water balls", "[tasks][table][rollout]") {
  TaskTempDir dir;
  const std::string file =
      dir.write("pour_water.yaml", edit_once(default_yaml("pour_water"), "count: 8", "count: 30"));
  auto env = make_env("pour_water", 8, 3, 0, file);
  CHECK(mj_name2id(env->model().mj(), mjOBJ_BODY, "water29") >= 0);
  std::mt19937_64 rng(4);
  std::vector<float> a(8 * static_cast<size_t>(env->act_dim()));
  for (int i = 0; i < 60; ++i) {
    random_actions(a, rng);
    env->step(a);
  }
  CHECK(env->batch().total_faults() == 0);
  for (float x : env->obs) CHECK(std::isfinite(x));
}

// ---- rollouts and determinism -------------------------------------------------------------

TEST_CASE("table family: random actions give finite results at 3 and 16 slots",
          "[tasks][table][rollout]") {
  for (const auto& id : kIds) {
    for (auto [nslot, steps] : {std::pair{3, 160}, std::pair{16, 60}}) {
      INFO("task " << id << ", " << nslot << " slots");
      auto env = make_env(id, nslot, 41);
      std::mt19937_64 rng(42);
      std::vector<float> a(static_cast<size_t>(nslot) * env->act_dim());
      int64_t bad = 0, mismatch = 0;
      for (int i = 0; i < steps; ++i) {
        random_actions(a, rng);
        env->step(a);
        for (float x : env->obs) bad += !std::isfinite(x) || std::abs(x) > 5.f;
        for (float x : env->terms) bad += !std::isfinite(x);
        for (int s = 0; s < nslot; ++s) {
          double sum = 0;
          for (int k = 0; k < env->nterms(); ++k)
            sum += env->terms[static_cast<size_t>(s) * env->nterms() + k];
          mismatch += std::abs(sum - env->reward[s]) > 1e-4 * (1 + std::abs(sum));
        }
      }
      CHECK(bad == 0);
      CHECK(mismatch == 0);
      CHECK(env->batch().total_faults() == 0);
    }
  }
}

TEST_CASE("table family: same seed gives bitwise identical trajectories for 1 and 2 threads",
          "[tasks][table][determinism]") {
  for (const auto& id : kIds) {
    INFO("task " << id);
    auto run = [&](int threads) {
      auto env = make_env(id, 4, 9, threads);
      std::mt19937_64 rng(10);
      std::vector<float> a(4 * static_cast<size_t>(env->act_dim())), trace;
      for (int i = 0; i < 40; ++i) {
        random_actions(a, rng);
        env->step(a);
        trace.insert(trace.end(), env->obs.begin(), env->obs.end());
        trace.insert(trace.end(), env->reward.begin(), env->reward.end());
      }
      return trace;
    };
    const auto one = run(1), two = run(2);
    REQUIRE(one.size() == two.size());
    CHECK(std::memcmp(one.data(), two.data(), one.size() * sizeof(float)) == 0);
  }
}

// ---- YAML errors --------------------------------------------------------------------------

TEST_CASE("bad table family YAML files are ConfigErrors naming file, key, expected, actual",
          "[tasks][table][config]") {
  struct Bad {
    const char* task;
    std::function<std::string(std::string)> edit;
    const char* key;
    const char* expected;
    const char* actual;
  };
  const std::vector<Bad> cases = {
      {"swing_cup", [](std::string t) { return t + "colour: red\n"; }, "colour", "one of the keys",
       "unknown key 'colour'"},
      {"scissors", [](std::string t) { return edit_once(t, "reward:\n", "reward:\n  bonus: 1\n"); },
       "reward.bonus", "angle_scale", "unknown key 'bonus'"},
      {"pen", [](std::string t) { return remove_key(t, "separation_offset"); },
       "reward.separation_offset", "a value for the required key", "none"},
      {"switch", [](std::string t) { return remove_key(t, "joint_damping"); },
       "object.joint_damping", "a value for the required key", "none"},
      {"pour_water", [](std::string t) { return set_value(t, "episode_length", "long"); },
       "episode_length", "an integer", "long"},
      {"pour_water", [](std::string t) { return edit_once(t, "count: 8", "count: 31"); },
       "water.count", "a count in [0, 30]", "31"},
      {"pour_water", [](std::string t) { return set_value(t, "lift_max", "2"); },
       "reward.lift_max", "a height in [0, 1] m", "2"},
      {"scissors", [](std::string t) { return set_value(t, "joint_angle", "1.2"); },
       "reset.joint_angle", "inside the joint range", "1.2"},
      {"swing_cup", [](std::string t) { return set_value(t, "rot_eps", "0"); }, "reward.rot_eps",
       "an epsilon", "0"},
      {"switch", [](std::string t) { return t + "termination: {drop_height: 0.1}\n"; },
       "termination", "one of the keys", "unknown key 'termination'"},
      {"swing_cup", [](std::string t) { return edit_once(t, "size: [0.3, 0.3, 0.6]", "size: [0.3, 0, 0.6]"); },
       "table.size", "sizes > 0", "0.3, 0, 0.6"},
      {"pen", [](std::string t) { return set_value(t, "max_reach", "yes"); },
       "termination.max_reach", "a number", "yes"},
      // reward variants (tasks/README.md)
      {"switch", [](std::string t) { return set_value(t, "variant", "code"); }, "reward.variant",
       "'original' or 'paper'", "code"},
      {"switch", [](std::string t) { return set_value(t, "paper", "{press_offset: -2000}"); },
       "reward.paper.press_offset", "an offset in [-1000, 1000]", "-2000"},
      {"switch", [](std::string t) { return set_value(t, "paper", "{gate: 0.7}"); },
       "reward.paper.gate", "a key of 'reward'", "'gate'"},
  };
  for (const auto& c : cases) {
    INFO("task " << c.task << ", key " << c.key);
    TaskTempDir dir;
    const std::string file = dir.write(std::string(c.task) + ".yaml", c.edit(default_yaml(c.task)));
    const auto e = thrown<ConfigError>([&] { tasks::make_task(c.task, file); });
    const std::string what = e.what();
    INFO("what(): " << what);
    CHECK(contains(what, file));
    CHECK(e.key() == c.key);
    CHECK(contains(e.expected(), c.expected));
    CHECK(contains(e.actual(), c.actual));
  }
  // and the defaults load
  for (const auto& id : kIds) CHECK_NOTHROW(tasks::make_task(id));
}

// ---- soak ---------------------------------------------------------------------------------
// tests/tasks/task_fixture.h soak_task, on episodes cut to 60 steps so that every slot resets
// inside step
TEST_CASE("soak: swing_cup: 50k random slot-steps without a fault", "[tasks][table][soak]") {
  soak_task("swing_cup", 60);
}
TEST_CASE("soak: scissors: 50k random slot-steps without a fault", "[tasks][table][soak]") {
  soak_task("scissors", 60);
}
TEST_CASE("soak: pen: 50k random slot-steps without a fault", "[tasks][table][soak]") {
  soak_task("pen", 60);
}
TEST_CASE("soak: switch: 50k random slot-steps without a fault", "[tasks][table][soak]") {
  soak_task("switch", 60);
}
TEST_CASE("soak: pour_water: 50k random slot-steps without a fault", "[tasks][table][soak]") {
  soak_task("pour_water", 60);
}
