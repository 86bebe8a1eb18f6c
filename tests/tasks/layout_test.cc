// tasks/spec + observe/apply_actions of the catch family: the observation and action layouts of
// the five tasks against the paper's index tables (written out below by hand), the agents of
// the multi-agent split, and what a live environment writes into each slice.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "tasks/spec.h"
#include "tests/paper_table.h"
#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

namespace {

// One row of a paper table: a slice and its first and last index (inclusive, as printed).
struct Row {
  const char* name;
  int first, last;
};

// The paper's "Observation space of dual Shadow Hands" (free bases, 199 per hand).
const std::vector<Row> kFreeHands = {
    {"right.dof_pos", 0, 23},          {"right.dof_vel", 24, 47},
    {"right.dof_force", 48, 71},       {"right.fingertip_state", 72, 136},
    {"right.fingertip_force", 137, 166}, {"right.base_pos", 167, 169},
    {"right.base_rot", 170, 172},      {"right.actions", 173, 198},
    {"left.dof_pos", 199, 222},        {"left.dof_vel", 223, 246},
    {"left.dof_force", 247, 270},      {"left.fingertip_state", 271, 335},
    {"left.fingertip_force", 336, 365}, {"left.base_pos", 366, 368},
    {"left.base_rot", 369, 371},       {"left.actions", 372, 397},
};

// Hand Over's fixed bases: the same rows without base position/rotation and with 20 actions
// (187 per hand; the paper: "reduced 24 dimensions"; the original's offsets 0/24/48/72/137/167).
const std::vector<Row> kFixedHands = {
    {"right.dof_pos", 0, 23},          {"right.dof_vel", 24, 47},
    {"right.dof_force", 48, 71},       {"right.fingertip_state", 72, 136},
    {"right.fingertip_force", 137, 166}, {"right.actions", 167, 186},
    {"left.dof_pos", 187, 210},        {"left.dof_vel", 211, 234},
    {"left.dof_force", 235, 258},      {"left.fingertip_state", 259, 323},
    {"left.fingertip_force", 324, 353}, {"left.actions", 354, 373},
};

// The task tails: Hand Over 374-397; the 422-wide tasks 398-421; Two Catch Underarm 398-445.
const std::vector<Row> kHandOverTail = {
    {"object.pose", 374, 380}, {"object.linvel", 381, 383}, {"object.angvel", 384, 386},
    {"goal.pose", 387, 393},   {"goal.rot_diff", 394, 397},
};
const std::vector<Row> kCatchTail = {
    {"object.pose", 398, 404}, {"object.linvel", 405, 407}, {"object.angvel", 408, 410},
    {"goal.pose", 411, 417},   {"goal.rot_diff", 418, 421},
};
const std::vector<Row> kTwoCatchTail = {
    {"object1.pose", 398, 404}, {"object1.linvel", 405, 407}, {"object1.angvel", 408, 410},
    {"goal1.pose", 411, 417},   {"goal1.rot_diff", 418, 421}, {"object2.pose", 422, 428},
    {"object2.linvel", 429, 431}, {"object2.angvel", 432, 434}, {"goal2.pose", 435, 441},
    {"goal2.rot_diff", 442, 445},
};

// The action tables: Hand Over 40, the others 52 (joints, then base translation, rotation).
const std::vector<Row> kFixedActions = {{"right.joints", 0, 19}, {"left.joints", 20, 39}};
const std::vector<Row> kFreeActions = {
    {"right.joints", 0, 19},           {"right.base_translation", 20, 22},
    {"right.base_rotation", 23, 25},   {"left.joints", 26, 45},
    {"left.base_translation", 46, 48}, {"left.base_rotation", 49, 51},
};

struct PaperTask {
  const char* id;
  int obs_dim, act_dim, agent_obs_dim, agent_act_dim, episode_length;
  std::vector<Row> obs, act;
  std::vector<std::string> terms;
};

std::vector<Row> cat(std::vector<Row> a, const std::vector<Row>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

const std::vector<PaperTask>& paper_tasks() {
  static const std::vector<PaperTask> t = {
      {"hand_over", 398, 40, 211, 20, 75, cat(kFixedHands, kHandOverTail), kFixedActions,
       {"pose", "goal_bonus", "fall_penalty", "action_penalty"}},
      {"catch_underarm", 422, 52, 223, 26, 75, cat(kFreeHands, kCatchTail), kFreeActions,
       {"pose", "goal_bonus", "fall_penalty", "action_penalty"}},
      {"catch_over2underarm", 422, 52, 223, 26, 75, cat(kFreeHands, kCatchTail), kFreeActions,
       {"pose", "goal_bonus", "fall_penalty", "action_penalty"}},
      {"catch_abreast", 422, 52, 223, 26, 150, cat(kFreeHands, kCatchTail), kFreeActions,
       {"pose", "goal_bonus", "fall_penalty", "action_penalty"}},
      {"two_catch_underarm", 446, 52, 247, 26, 75, cat(kFreeHands, kTwoCatchTail), kFreeActions,
       {"pose_object1", "pose_object2", "goal_bonus", "fall_penalty", "action_penalty"}},
  };
  return t;
}

void check_rows(const tasks::Layout& l, const std::vector<Row>& rows) {
  REQUIRE(l.slices().size() == rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto& s = l.slices()[i];
    INFO("paper row " << rows[i].name << " " << rows[i].first << "-" << rows[i].last);
    CHECK(s.name == rows[i].name);
    CHECK(s.start == rows[i].first);
    CHECK(s.end() - 1 == rows[i].last);
    const tasks::Slice* f = l.find(rows[i].name);
    REQUIRE(f != nullptr);
    CHECK(f->start == rows[i].first);
    // goal slices are exactly the goal pose and the rotation difference
    const std::string n = rows[i].name;
    CHECK(s.goal == (n.rfind("goal", 0) == 0));
  }
}

double wrap_diff(double a, double b) {  // distance of two angles on the circle
  double d = std::fmod(std::abs(a - b), 2 * M_PI);
  return std::min(d, 2 * M_PI - d);
}

// Roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll) from a (w, x, y, z) quaternion, through
// the rotation matrix (not the code's closed form).
std::array<double, 3> rpy_of(const double* q) {
  double R[9];
  mju_quat2Mat(R, q);
  // R = Rz Ry Rx: R[2][0] = -sin(pitch), R[2][1] = cos(pitch) sin(roll), R[1][0] = cos(pitch) sin(yaw)
  const double pitch = std::asin(std::clamp(-R[6], -1.0, 1.0));
  const double roll = std::atan2(R[7], R[8]);
  const double yaw = std::atan2(R[3], R[0]);
  return {roll, pitch, yaw};
}

}  // namespace

TEST_CASE("the registry holds the paper's twenty tasks in the canonical table's order",
          "[tasks][layout]") {
  // TASKS.md's table, written out here
  const std::vector<std::string> ids = {
      "hand_over",         "catch_underarm",   "catch_over2underarm", "catch_abreast",
      "two_catch_underarm", "lift_underarm",   "door_open_outward",   "door_close_inward",
      "door_open_inward",  "door_close_outward", "bottle_cap",        "push_block",
      "swing_cup",         "scissors",         "re_orientation",      "pen",
      "switch",            "block_stack",      "pour_water",          "grasp_and_place"};
  std::vector<std::string> got;
  for (auto& e : tasks::task_registry()) {
    got.push_back(e.spec().id);
    CHECK(e.spec().variant_of.empty());
  }
  CHECK(got == ids);
  // variants are found by id but are not among the twenty
  std::vector<std::string> variants;
  for (auto& e : tasks::variant_registry()) {
    variants.push_back(e.spec().id);
    CHECK_FALSE(e.spec().variant_of.empty());
    CHECK(std::find(ids.begin(), ids.end(), e.spec().id) == ids.end());
    CHECK(std::find(ids.begin(), ids.end(), e.spec().variant_of) != ids.end());
    CHECK(&tasks::find_task(e.spec().id) == &e);
  }
  CHECK(variants == std::vector<std::string>{"catch_underarm_raise", "hand_over_free"});
}

TEST_CASE("hand_over_free is hand_over with catch_underarm's free-base layouts",
          "[tasks][layout]") {
  const tasks::TaskSpec& v = tasks::find_task("hand_over_free").spec();
  const tasks::TaskSpec& ho = tasks::find_task("hand_over").spec();
  const tasks::TaskSpec& cu = tasks::find_task("catch_underarm").spec();
  CHECK(v.variant_of == "hand_over");
  CHECK(v.free_base);
  CHECK(v.obs.dim() == 422);
  CHECK(v.act.dim() == 52);
  CHECK(v.age.text == ho.age.text);
  CHECK(v.difficulty == ho.difficulty);
  CHECK(v.skill == ho.skill);
  CHECK(v.episode_length == ho.episode_length);
  REQUIRE(v.obs.slices().size() == cu.obs.slices().size());
  for (size_t i = 0; i < v.obs.slices().size(); ++i) {
    CHECK(v.obs.slices()[i].name == cu.obs.slices()[i].name);
    CHECK(v.obs.slices()[i].start == cu.obs.slices()[i].start);
    CHECK(v.obs.slices()[i].goal == cu.obs.slices()[i].goal);
  }
  std::vector<std::string> terms_v, terms_ho;
  for (auto& t : v.reward_terms) terms_v.push_back(t.name);
  for (auto& t : ho.reward_terms) terms_ho.push_back(t.name);
  CHECK(terms_v == terms_ho);
}

// (the catch family's; every other family's test file checks its own tasks the same way)
TEST_CASE("every task's layouts are the paper's index tables", "[tasks][layout]") {
  REQUIRE(tasks::task_registry().size() >= paper_tasks().size());
  for (size_t i = 0; i < paper_tasks().size(); ++i) {
    const auto& p = paper_tasks()[i];
    INFO("task " << p.id);
    const tasks::TaskSpec& sp = tasks::find_task(p.id).spec();
    CHECK(tasks::task_registry()[i].spec().id == p.id);  // the paper's order
    CHECK(sp.id == p.id);
    CHECK(sp.obs.dim() == p.obs_dim);
    CHECK(sp.act.dim() == p.act_dim);
    CHECK(sp.episode_length == p.episode_length);
    CHECK(sp.free_base == (p.act_dim == 52));
    check_rows(sp.obs, p.obs);
    check_rows(sp.act, p.act);

    std::vector<std::string> terms;
    for (auto& t : sp.reward_terms) terms.push_back(t.name);
    CHECK(terms == p.terms);

    // agents: one per hand, its own hand block plus the whole task tail, its own actions
    REQUIRE(sp.agents.size() == 2);
    const int hand_obs = p.obs_dim == 398 ? 187 : 199;
    for (int a = 0; a < 2; ++a) {
      const auto& ag = sp.agents[a];
      const std::string side = a == 0 ? "right" : "left", other = a == 0 ? "left." : "right.";
      INFO("agent " << ag.name);
      CHECK(ag.name == side);
      int od = 0, ad = 0, hand = 0;
      for (auto& n : ag.obs) {
        const auto& s = sp.obs.at(n);
        od += s.size;
        CHECK(n.rfind(other, 0) != 0);
        if (n.rfind(side + ".", 0) == 0) {
          hand += s.size;
          CHECK(s.start >= a * hand_obs);
          CHECK(s.end() <= (a + 1) * hand_obs);
        } else {
          CHECK(s.start >= 2 * hand_obs);  // the tail
        }
      }
      CHECK(od == p.agent_obs_dim);
      CHECK(hand == hand_obs);
      CHECK(od == p.obs_dim - hand_obs);  // upstream: total minus one hand block
      for (auto& n : ag.act) {
        const auto& s = sp.act.at(n);
        ad += s.size;
        CHECK(s.start >= a * p.agent_act_dim);
        CHECK(s.end() <= (a + 1) * p.agent_act_dim);
      }
      CHECK(ad == p.agent_act_dim);
    }
    // and a live environment has these sizes
    auto env = make_env(p.id, 1);
    CHECK(env->obs_dim() == p.obs_dim);
    CHECK(env->act_dim() == p.act_dim);
    CHECK(env->nterms() == static_cast<int>(p.terms.size()));
    CHECK(env->obs.size() == static_cast<size_t>(p.obs_dim));
    CHECK(env->task().episode_length() == p.episode_length);
  }
}

TEST_CASE("Layout::at names the slices when one is missing", "[tasks][layout]") {
  const auto& sp = tasks::find_task("catch_underarm").spec();
  auto e = thrown<Error>([&] { sp.obs.at("object.colour"); });
  CHECK(contains(e.what(), "object.colour"));
  CHECK(contains(e.what(), "goal.rot_diff"));
  CHECK(sp.obs.find("object.colour") == nullptr);
  CHECK(sp.term_index("pose") == 0);
  CHECK(sp.term_index("nope") == -1);
}

// What each observation slice holds on a live environment, checked against the MuJoCo state
// computed independently (body positions, mj_objectVelocity, the paper's joint limits).
TEST_CASE("observation slices hold what their names say", "[tasks][layout][obs]") {
  for (const char* id : kTaskIds) {
    INFO("task " << id);
    const int nslot = 3;
    auto env = make_env(id, nslot, 11);
    const auto& sp = env->spec();
    const mjModel* m = env->model().mj();
    const int nobj = sp.obs.find("object.pose") ? 1 : 2;
    const int per_hand = sp.act.dim() / 2;

    // right after reset: no actions yet
    for (int s = 0; s < nslot; ++s)
      for (const char* side : {"right.actions", "left.actions"})
        for (float x : obs_slice(*env, env->obs, s, side)) CHECK(x == 0.f);

    std::mt19937_64 rng(3);
    std::vector<float> a(static_cast<size_t>(nslot) * env->act_dim());
    int clipped_seen = 0, checked = 0;
    double biggest_tip_force = 0;
    for (int step = 0; step < 6; ++step) {
      random_actions(a, rng, -1.6f, 1.6f);  // some outside [-1, 1]: clipped
      env->step(a);
      for (int s = 0; s < nslot; ++s) {
        INFO("step " << step << " slot " << s);
        const float* as = a.data() + static_cast<size_t>(s) * env->act_dim();
        const bool done = env->terminated[s] || env->truncated[s];
        // actions: this step's, clipped, per hand in paper order; zeros after an in-step reset
        for (int h = 0; h < 2; ++h) {
          auto got = obs_slice(*env, env->obs, s, h == 0 ? "right.actions" : "left.actions");
          REQUIRE(static_cast<int>(got.size()) == per_hand);
          for (int k = 0; k < per_hand; ++k)
            CHECK(got[k] == (done ? 0.f : std::clamp(as[h * per_hand + k], -1.f, 1.f)));
        }
        // every value clipped to [-5, 5]; the unclipped observation agrees elsewhere
        const float* row = env->obs.data() + static_cast<size_t>(s) * env->obs_dim();
        auto raw = observe(*env, s);
        for (int k = 0; k < env->obs_dim(); ++k) {
          CHECK(std::abs(row[k]) <= 5.f);
          if (std::abs(raw[k]) > 5.f) {
            ++clipped_seen;
            CHECK(row[k] == std::copysign(5.f, raw[k]));
          } else {
            CHECK(row[k] == raw[k]);
          }
        }
        if (done) continue;
        ++checked;
        mjData* d = env->batch().data(s);
        const double* xpos = env->batch().xpos.data() + static_cast<size_t>(s) * 3 * m->nbody;
        const double* xquat = env->batch().xquat.data() + static_cast<size_t>(s) * 4 * m->nbody;
        // objects: position and (x, y, z, w) quaternion of the body; velocities of its origin
        for (int i = 0; i < nobj; ++i) {
          const std::string n = nobj == 1 ? "" : std::to_string(i + 1);
          const int b = object_of(*env, "object" + n).body;
          auto pose = obs_slice(*env, raw, 0, "object" + n + ".pose");
          for (int k = 0; k < 3; ++k) CHECK(pose[k] == static_cast<float>(xpos[3 * b + k]));
          CHECK(pose[3] == static_cast<float>(xquat[4 * b + 1]));
          CHECK(pose[4] == static_cast<float>(xquat[4 * b + 2]));
          CHECK(pose[5] == static_cast<float>(xquat[4 * b + 3]));
          CHECK(pose[6] == static_cast<float>(xquat[4 * b + 0]));
          mjtNum vel[6];  // (angular, linear) at the body frame origin (XBODY), world frame
          mj_objectVelocity(m, d, mjOBJ_XBODY, b, vel, 0);
          auto lin = obs_slice(*env, raw, 0, "object" + n + ".linvel");
          auto ang = obs_slice(*env, raw, 0, "object" + n + ".angvel");
          for (int k = 0; k < 3; ++k) {
            CHECK(lin[k] == Approx(vel[3 + k]).margin(1e-5));
            CHECK(ang[k] == Approx(0.2 * vel[k]).margin(1e-5));
          }
          // goal pose and the rotation difference object * conj(goal), (x, y, z, w)
          const auto& g = env->slot_state(s).goal[i];
          auto gp = obs_slice(*env, raw, 0, "goal" + n + ".pose");
          for (int k = 0; k < 3; ++k) CHECK(gp[k] == static_cast<float>(g[k]));
          CHECK(gp[3] == static_cast<float>(g[4]));
          CHECK(gp[6] == static_cast<float>(g[3]));
          const Q qo{xquat[4 * b], xquat[4 * b + 1], xquat[4 * b + 2], xquat[4 * b + 3]};
          const Q diff = qmul(qo, qconj({g[3], g[4], g[5], g[6]}));
          auto rd = obs_slice(*env, raw, 0, "goal" + n + ".rot_diff");
          CHECK(rd[0] == Approx(diff[1]).margin(1e-6));
          CHECK(rd[1] == Approx(diff[2]).margin(1e-6));
          CHECK(rd[2] == Approx(diff[3]).margin(1e-6));
          CHECK(rd[3] == Approx(diff[0]).margin(1e-6));
        }
        for (const auto& hand : env->model().hands()) {
          const std::string side = hand.side == sim::Side::kRight ? "right." : "left.";
          // fingertips ff, mf, rf, lf, th: distal body origin state, world frame
          const char* tips[5] = {"ffdistal", "mfdistal", "rfdistal", "lfdistal", "thdistal"};
          auto ts = obs_slice(*env, raw, 0, side + "fingertip_state");
          for (int t = 0; t < 5; ++t) {
            const int b = body_id(*env, hand.prefix + tips[t]);
            const float* o = ts.data() + 13 * t;
            for (int k = 0; k < 3; ++k) CHECK(o[k] == static_cast<float>(xpos[3 * b + k]));
            CHECK(o[3] == static_cast<float>(xquat[4 * b + 1]));
            CHECK(o[6] == static_cast<float>(xquat[4 * b + 0]));
            mjtNum vel[6];
            mj_objectVelocity(m, d, mjOBJ_XBODY, b, vel, 0);
            for (int k = 0; k < 3; ++k) {
              CHECK(o[7 + k] == Approx(vel[3 + k]).margin(1e-5));
              CHECK(o[10 + k] == Approx(vel[k]).margin(1e-5));
            }
          }
          // fingertip force/torque sensors x10 (moving fingers: non-zero)
          auto ff = obs_slice(*env, raw, 0, side + "fingertip_force");
          const double* sd = env->batch().sensordata.data() + static_cast<size_t>(s) * m->nsensordata;
          for (int t = 0; t < 5; ++t)
            for (int k = 0; k < 3; ++k) {
              const double f = sd[hand.tip_force_adr[t] + k], tq = sd[hand.tip_torque_adr[t] + k];
              CHECK(ff[6 * t + k] == Approx(10 * f).epsilon(1e-6).margin(1e-6));
              CHECK(ff[6 * t + 3 + k] == Approx(10 * tq).epsilon(1e-6).margin(1e-6));
              biggest_tip_force = std::max(biggest_tip_force, std::abs(f));
            }
          if (sp.free_base) {  // the base: the forearm (root) position and its roll, pitch, yaw
            const int b = body_id(*env, hand.prefix + "forearm");
            CHECK(b == hand.root_body);
            auto bp = obs_slice(*env, raw, 0, side + "base_pos");
            for (int k = 0; k < 3; ++k) CHECK(bp[k] == static_cast<float>(xpos[3 * b + k]));
            auto br = obs_slice(*env, raw, 0, side + "base_rot");
            auto e = rpy_of(xquat + 4 * b);
            for (int k = 0; k < 3; ++k) {
              CHECK(br[k] >= 0.f);
              CHECK(br[k] <= static_cast<float>(2 * M_PI));
              CHECK(wrap_diff(br[k], e[k]) < 1e-4);
            }
          }
        }
      }
    }
    CHECK(checked > 0);
    CHECK(clipped_seen > 0);  // the [-5, 5] clip was exercised
    CHECK(biggest_tip_force > 1e-3);  // newtons: real forces were compared
  }
}

TEST_CASE("joint observations map limits to -1 and +1 and scale velocity by 0.2 and forces by 10",
          "[tasks][layout][obs]") {
  for (const char* id : {"hand_over", "catch_underarm"}) {
    INFO("task " << id);
    auto env = make_env(id, 1, 5);
    const mjModel* m = env->model().mj();
    mjData* d = env->batch().data(0);
    // right hand: even joints (paper order) at the paper's lower limit, odd ones at the upper;
    // left hand: every joint in the middle of its range, moving at a known speed
    for (size_t j = 0; j < kPaperJoints.size(); ++j) {
      const auto& pj = kPaperJoints[j];
      const int jr = mj_name2id(m, mjOBJ_JOINT, (std::string("rh_") + pj.name).c_str());
      const int jl = mj_name2id(m, mjOBJ_JOINT, (std::string("lh_") + pj.name).c_str());
      REQUIRE(jr >= 0);
      REQUIRE(jl >= 0);
      d->qpos[m->jnt_qposadr[jr]] = (j % 2 == 0 ? pj.min_deg : pj.max_deg) * kDegToRad;
      d->qpos[m->jnt_qposadr[jl]] = 0.5 * (pj.min_deg + pj.max_deg) * kDegToRad;
      d->qvel[m->jnt_dofadr[jr]] = 0;
      d->qvel[m->jnt_dofadr[jl]] = -1.2 + 0.1 * static_cast<double>(j);
    }
    sync(*env, 0);
    auto o = observe(*env, 0);
    auto rp = obs_slice(*env, o, 0, "right.dof_pos");
    auto lp = obs_slice(*env, o, 0, "left.dof_pos");
    auto lv = obs_slice(*env, o, 0, "left.dof_vel");
    for (size_t j = 0; j < kPaperJoints.size(); ++j) {
      INFO("joint " << kPaperJoints[j].name);
      CHECK(rp[j] == Approx(j % 2 == 0 ? -1.0 : 1.0).margin(1e-5));
      CHECK(lp[j] == Approx(0.0).margin(1e-5));
      CHECK(lv[j] == Approx(0.2 * (-1.2 + 0.1 * static_cast<double>(j))).margin(1e-6));
    }
    // forces: x10 of the motor torque (driven joints) or the coupling torque (distal joints)
    const auto& v = env->batch();
    for (const auto& hand : env->model().hands()) {
      const std::string side = hand.side == sim::Side::kRight ? "right." : "left.";
      auto f = obs_slice(*env, o, 0, side + "dof_force");
      int nonzero = 0;
      for (size_t j = 0; j < kPaperJoints.size(); ++j) {
        const auto& pj = kPaperJoints[j];
        INFO(side << pj.name);
        const int jid = mj_name2id(m, mjOBJ_JOINT, (hand.prefix + pj.name).c_str());
        const int dof = m->jnt_dofadr[jid];
        const double want = 10 * (pj.actuated ? v.qfrc_actuator[dof] : v.qfrc_constraint[dof]);
        CHECK(f[j] == Approx(want).margin(1e-5));
        nonzero += std::abs(f[j]) > 1e-3;
      }
      CHECK(nonzero > 0);
      // fingertip force/torque sensors x10
      auto ff = obs_slice(*env, o, 0, side + "fingertip_force");
      for (int t = 0; t < 5; ++t)
        for (int k = 0; k < 3; ++k) {
          CHECK(ff[6 * t + k] == Approx(10 * v.sensordata[hand.tip_force_adr[t] + k]).margin(1e-5));
          CHECK(ff[6 * t + 3 + k] ==
                Approx(10 * v.sensordata[hand.tip_torque_adr[t] + k]).margin(1e-5));
        }
    }
  }
}

TEST_CASE("goal rotation difference of a crafted pose", "[tasks][layout][obs]") {
  auto env = make_env("catch_underarm", 1, 1);
  // object at identity, goal turned 0.3 rad about x: object * conj(goal) = conj(goal)
  place_object(*env, 0, "object", {0, -0.39, 0.6}, {1, 0, 0, 0});
  set_goal(*env, 0, 0, {0.1, -0.79, 0.55}, qaxis(1, 0, 0, 0.3));
  sync(*env, 0);
  auto o = observe(*env, 0);
  auto rd = obs_slice(*env, o, 0, "goal.rot_diff");
  // (x, y, z, w) = (-sin 0.15, 0, 0, cos 0.15)
  CHECK(rd[0] == Approx(-0.1494381325).margin(1e-6));
  CHECK(rd[1] == Approx(0).margin(1e-7));
  CHECK(rd[2] == Approx(0).margin(1e-7));
  CHECK(rd[3] == Approx(0.9887710779).margin(1e-6));
  auto gp = obs_slice(*env, o, 0, "goal.pose");
  CHECK(gp[0] == Approx(0.1));
  CHECK(gp[1] == Approx(-0.79));
  CHECK(gp[2] == Approx(0.55));
  CHECK(gp[3] == Approx(0.1494381325).margin(1e-6));
  CHECK(gp[6] == Approx(0.9887710779).margin(1e-6));
  auto op = obs_slice(*env, o, 0, "object.pose");
  CHECK(op[1] == Approx(-0.39));
  CHECK(op[2] == Approx(0.6));
  CHECK(op[6] == 1.f);
}

// apply_actions: the paper's action order, joint targets over each joint's range, base forces
// at the YAML's scale (catch_underarm: 0.05 x 1e5 / 60 = 83.33 N, 0.5 x 1e3 / 60 = 8.333 N m).
TEST_CASE("actions map to joint targets and base forces in the paper's order",
          "[tasks][layout][actions]") {
  for (const char* id : {"hand_over", "catch_underarm"}) {
    INFO("task " << id);
    auto env = make_env(id, 1, 1);
    const mjModel* m = env->model().mj();
    const bool free = env->spec().free_base;
    const int per_hand = free ? 26 : 20;
    std::vector<float> a(env->act_dim());
    // right joints alternate -1, +1; left joints 0; right base (+1, -0.5, 0.25 | -1, 0.5, 0)
    std::vector<int> actuated;
    for (size_t j = 0; j < kPaperJoints.size(); ++j)
      if (kPaperJoints[j].actuated) actuated.push_back(static_cast<int>(j));
    REQUIRE(actuated.size() == 20);
    for (int k = 0; k < 20; ++k) {
      a[k] = k % 2 == 0 ? -1.f : 1.f;
      a[per_hand + k] = 0.f;
    }
    if (free) {
      const float base[6] = {1.f, -0.5f, 0.25f, -1.f, 0.5f, 0.f};
      for (int k = 0; k < 6; ++k) {
        a[20 + k] = base[k];
        a[per_hand + 20 + k] = -base[k];
      }
    }
    tasks::TaskSlot t = env->slot(0);
    env->task().apply_actions(a.data(), t);
    for (int k = 0; k < 20; ++k) {
      const auto& pj = kPaperJoints[actuated[k]];
      INFO("actuator " << k << " " << pj.name);
      const int ar = mj_name2id(m, mjOBJ_ACTUATOR, (std::string("rh_") + pj.name).c_str());
      const int al = mj_name2id(m, mjOBJ_ACTUATOR, (std::string("lh_") + pj.name).c_str());
      REQUIRE(ar >= 0);
      REQUIRE(al >= 0);
      CHECK(t.state.ctrl[ar] == Approx((k % 2 == 0 ? pj.min_deg : pj.max_deg) * kDegToRad).margin(1e-9));
      CHECK(t.state.ctrl[al] == Approx(0.5 * (pj.min_deg + pj.max_deg) * kDegToRad).margin(1e-9));
    }
    if (free) {
      const double F = 0.05 * 1e5 / 60, T = 0.5 * 1e3 / 60;  // 83.33 N, 8.333 N m
      const double want[6] = {F, -0.5 * F, 0.25 * F, -T, 0.5 * T, 0};
      for (const auto& hand : env->model().hands()) {
        const size_t h = static_cast<size_t>(&hand - env->model().hands().data());
        const double sign = hand.side == sim::Side::kRight ? 1 : -1;
        for (int k = 0; k < 6; ++k)
          CHECK(t.state.base_wrench[6 * h + k] == Approx(sign * want[k]).margin(1e-9));
      }
    }
  }
}
