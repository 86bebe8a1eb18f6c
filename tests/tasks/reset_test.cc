// tasks/catch_family reset + hands sample_joint_noise/set_hand_joints: over many resets (all
// slots at once, and single slots inside step), every sample lies inside its configured range:
// object positions, orientations, goals and their markers, hand joints, couplings and motor
// targets, free bases back at their mounts.
#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "tests/paper_table.h"
#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;

namespace {

struct ResetConfig {
  double position_noise, dof_noise;
  bool random_object_rotation, random_goal_rotation;
};

// What the reset samples covered, over all checked slots.
struct Coverage {
  int samples = 0;
  std::array<double, 3> max_offset{};   // largest |object offset| per axis
  int joints_nonzero = 0;               // joint values != 0
  int joints_clamped_low = 0;           // joints exactly at their lower limit != 0 ... or at 0
  std::set<std::array<double, 4>> object_quats, goal_quats;
};

// The original's random rotation q_x(pi r0) * q_y(pi r1) has w z == x y (and is unit).
void check_rotation(const double* q, bool random, const std::string& what) {
  INFO(what << " quaternion " << q[0] << " " << q[1] << " " << q[2] << " " << q[3]);
  CHECK(qnorm(q) == Approx(1.0).margin(1e-12));
  if (random) {
    CHECK(q[0] * q[3] == Approx(q[1] * q[2]).margin(1e-12));
  } else {
    CHECK(q[0] == 1.0);
    CHECK(q[1] == 0.0);
    CHECK(q[2] == 0.0);
    CHECK(q[3] == 0.0);
  }
}

// Every invariant of a freshly reset slot.
void check_reset_slot(tasks::TaskEnv& env, int s, const TaskFacts& f, const ResetConfig& c,
                      Coverage& cov) {
  INFO("slot " << s);
  const mjModel* m = env.model().mj();
  const mjData* d = env.batch().data(s);
  const auto& st = env.slot_state(s);
  cov.samples += 1;
  // the batch rows are the MuJoCo state
  const double* qrow = env.batch().qpos.data() + static_cast<size_t>(s) * m->nq;
  const double* crow = env.batch().ctrl.data() + static_cast<size_t>(s) * m->nu;
  const double* xpos = env.batch().xpos.data() + static_cast<size_t>(s) * 3 * m->nbody;
  const double* xquat = env.batch().xquat.data() + static_cast<size_t>(s) * 4 * m->nbody;
  CHECK(same_values(qrow, d->qpos, m->nq));
  CHECK(env.batch().time[s] == 0);
  // the task state: a new episode
  CHECK(st.progress == 0);
  CHECK_FALSE(st.success);
  CHECK_FALSE(st.bonus_paid);
  for (int k = 0; k < env.act_dim(); ++k) CHECK(st.action[k] == 0.f);

  // objects: start + one noise sample per axis shared by all objects, one orientation
  std::array<double, 3> offset0{};
  const double* quat0 = nullptr;
  for (int i = 0; i < f.nobj; ++i) {
    INFO("object " << i);
    const auto& o = object_of(env, object_name(f.nobj, i));
    const double* q = d->qpos + o.qpos_adr;
    for (int k = 0; k < 3; ++k) {
      const double off = q[k] - f.start[i][k];
      CHECK(std::abs(off) <= c.position_noise + 1e-12);
      if (i == 0) {
        offset0[k] = off;
        cov.max_offset[k] = std::max(cov.max_offset[k], std::abs(off));
      } else {
        CHECK(off == Approx(offset0[k]).margin(1e-12));
      }
      CHECK(xpos[3 * o.body + k] == Approx(q[k]).margin(1e-12));
    }
    check_rotation(q + 3, c.random_object_rotation, "object");
    if (i == 0) {
      quat0 = q + 3;
      cov.object_quats.insert({q[3], q[4], q[5], q[6]});
    } else {
      for (int k = 0; k < 4; ++k) CHECK(q[3 + k] == quat0[k]);
    }
    for (int k = 0; k < 6; ++k) CHECK(d->qvel[o.dof_adr + k] == 0);

    // goal i: the configured position, a unit orientation; the marker (mocap body) on it
    const auto& g = st.goal[i];
    for (int k = 0; k < 3; ++k) CHECK(g[k] == f.goal[i][k]);
    check_rotation(g.data() + 3, c.random_goal_rotation, "goal");
    if (i == 0) cov.goal_quats.insert({g[3], g[4], g[5], g[6]});
    else
      for (int k = 0; k < 4; ++k) CHECK(g[3 + k] == st.goal[0][3 + k]);
    const auto& marker = object_of(env, f.nobj == 1 ? "goal" : "goal" + std::to_string(i + 1));
    REQUIRE(marker.mocap >= 0);
    for (int k = 0; k < 3; ++k) {
      CHECK(d->mocap_pos[3 * marker.mocap + k] == g[k]);
      CHECK(xpos[3 * marker.body + k] == Approx(g[k]).margin(1e-12));
    }
    for (int k = 0; k < 4; ++k) {
      CHECK(d->mocap_quat[4 * marker.mocap + k] == Approx(g[3 + k]).margin(1e-12));  // MuJoCo renormalises it
      CHECK(xquat[4 * marker.body + k] == Approx(g[3 + k]).margin(1e-9));
    }
  }

  // hands: the same joint sample in both, inside the paper's ranges and inside the envelope
  // noise (l + (u - l) r), r in [-1, 1]; distal = middle; targets = angles; bases at mounts
  std::vector<double> right_q;
  for (const auto& hand : env.model().hands()) {
    const bool right = hand.side == sim::Side::kRight;
    INFO("hand " << hand.prefix);
    std::vector<double> q;
    for (const auto& pj : kPaperJoints) {
      INFO("joint " << pj.name);
      const int j = mj_name2id(m, mjOBJ_JOINT, (hand.prefix + pj.name).c_str());
      REQUIRE(j >= 0);
      const double lo = pj.min_deg * kDegToRad, hi = pj.max_deg * kDegToRad;
      const double x = d->qpos[m->jnt_qposadr[j]];
      q.push_back(x);
      // the model's ranges are the paper's to 1e-9 (MJCF text)
      CHECK(x >= lo - 1e-9);
      CHECK(x <= hi + 1e-9);
      const double n = c.dof_noise;
      CHECK(x >= std::max(lo, n * (2 * lo - hi)) - 1e-9);
      CHECK(x <= std::min(hi, n * hi) + 1e-9);
      CHECK(d->qvel[m->jnt_dofadr[j]] == 0);
      if (right) {
        cov.joints_nonzero += x != 0;
        cov.joints_clamped_low += lo == 0 && x == 0 && pj.actuated;
      }
    }
    for (const auto& cp : kPaperCouplings) {
      const int a = mj_name2id(m, mjOBJ_JOINT, (hand.prefix + cp[0]).c_str());
      const int b = mj_name2id(m, mjOBJ_JOINT, (hand.prefix + cp[1]).c_str());
      INFO("coupling " << cp[0] << " = " << cp[1]);
      CHECK(d->qpos[m->jnt_qposadr[a]] == d->qpos[m->jnt_qposadr[b]]);
    }
    if (right) right_q = q;
    else CHECK(q == right_q);
    for (int a = 0; a < m->nu; ++a) {
      const int j = m->actuator_trnid[2 * a];
      const std::string name = mj_id2name(m, mjOBJ_JOINT, j);
      if (name.rfind(hand.prefix, 0) != 0) continue;
      INFO("actuator of " << name);
      CHECK(crow[a] == d->qpos[m->jnt_qposadr[j]]);
      CHECK(d->ctrl[a] == d->qpos[m->jnt_qposadr[j]]);
    }
    const auto& mount = f.mounts[right ? 0 : 1];
    for (int k = 0; k < 3; ++k) CHECK(xpos[3 * hand.root_body + k] == Approx(mount[k]).margin(1e-9));
    if (f.free_base) {
      REQUIRE(hand.base_qpos_adr >= 0);
      const double want[7] = {0, 0, 0, 1, 0, 0, 0};  // slides, then the ball joint's quaternion
      for (int k = 0; k < 7; ++k) CHECK(d->qpos[hand.base_qpos_adr + k] == want[k]);
      for (int k = 0; k < 6; ++k) CHECK(d->qvel[hand.base_dof_adr + k] == 0);
    }
  }
}

void check_coverage(const Coverage& cov, const ResetConfig& c) {
  INFO("over " << cov.samples << " resets");
  for (int k = 0; k < 3; ++k) {
    INFO("axis " << k << ": largest offset " << cov.max_offset[k]);
    if (c.position_noise > 0) CHECK(cov.max_offset[k] > 0.8 * c.position_noise);
    else CHECK(cov.max_offset[k] == 0);
  }
  if (c.dof_noise > 0) {
    CHECK(cov.joints_nonzero > cov.samples * 10);  // most joints moved
    CHECK(cov.joints_clamped_low > 0);             // the clamp into the range was needed
  } else {
    CHECK(cov.joints_nonzero == 0);
  }
  const size_t distinct_obj = cov.object_quats.size(), distinct_goal = cov.goal_quats.size();
  CHECK(distinct_obj == (c.random_object_rotation ? static_cast<size_t>(cov.samples) : 1u));
  CHECK(distinct_goal == (c.random_goal_rotation ? static_cast<size_t>(cov.samples) : 1u));
}

}  // namespace

TEST_CASE("reset samples of every task stay inside their configured ranges",
          "[tasks][reset]") {
  for (const auto& f : task_facts()) {
    INFO("task " << f.id);
    const ResetConfig c{f.position_noise, f.dof_noise, true, true};
    Coverage cov;
    // 64 slots x 4 resets of all slots
    auto env = make_env(f.id, 64, 21);
    for (int round = 0; round < 4; ++round) {
      if (round > 0) env->reset();
      for (int s = 0; s < env->nslot(); ++s) check_reset_slot(*env, s, f, c, cov);
    }
    // the episode counter (the stream's seed) advanced at every reset
    CHECK(env->batch().episode[0] == 4);
    check_coverage(cov, c);
  }
}

TEST_CASE("resets inside step (finished slots) obey the same ranges", "[tasks][reset]") {
  for (const auto& f : task_facts()) {
    INFO("task " << f.id);
    const ResetConfig c{f.position_noise, f.dof_noise, true, true};
    Coverage cov;
    auto env = make_env(f.id, 8, 22);
    std::mt19937_64 rng(23);
    std::vector<float> a(static_cast<size_t>(env->nslot()) * env->act_dim());
    for (int step = 0; step < 120; ++step) {
      random_actions(a, rng);
      env->step(a);
      for (int s = 0; s < env->nslot(); ++s)
        if (env->terminated[s] || env->truncated[s]) check_reset_slot(*env, s, f, c, cov);
    }
    INFO("in-step resets checked: " << cov.samples);
    CHECK(cov.samples >= 8);
  }
}

TEST_CASE("reset follows edited YAML ranges without rotations and with wider noise", "[tasks][reset]") {
  TaskTempDir dir;
  for (const char* id : {"catch_underarm", "two_catch_underarm", "hand_over"}) {
    INFO("task " << id);
    TaskFacts f = facts(id);
    const ResetConfig c{0.05, 1.0, false, false};
    const std::string yaml =
        edited_yaml(dir, id,
                    {{"object_position_noise", "0.05"}, {"hand_dof_noise", "1.0"},
                     {"random_object_rotation", "false"}, {"random_goal_rotation", "false"}});
    auto env = make_env(id, 64, 24, 0, yaml);
    Coverage cov;
    for (int round = 0; round < 2; ++round) {
      if (round > 0) env->reset();
      for (int s = 0; s < env->nslot(); ++s) check_reset_slot(*env, s, f, c, cov);
    }
    check_coverage(cov, c);
  }
  // and with rotations but no noise at all
  const std::string yaml = edited_yaml(dir, "catch_underarm",
                                       {{"object_position_noise", "0"}, {"hand_dof_noise", "0"}},
                                       "quiet.yaml");
  auto env = make_env("catch_underarm", 32, 25, 0, yaml);
  Coverage cov;
  for (int s = 0; s < env->nslot(); ++s)
    check_reset_slot(*env, s, facts("catch_underarm"), {0, 0, true, true}, cov);
  check_coverage(cov, {0, 0, true, true});
}

// Reset states the physics must start from cleanly.

// two_catch_underarm: both eggs can rest in the palms at once; their contacts must fit the
// scene's arena (more than one-object scenes get), or MuJoCo warns (constraint or contact buffer
// full) and the batch faults the slot on its first step.
TEST_CASE("two_catch_underarm reset states fit the arena", "[tasks][reset]") {
  auto env = make_env("two_catch_underarm", 256, 1);
  const mjModel* m = env->model().mj();
  int full = 0;
  for (int s = 0; s < env->nslot(); ++s) {
    const mjData* d = env->batch().data(s);
    full += d->warning[mjWARN_CNSTRFULL].number > 0 || d->warning[mjWARN_CONTACTFULL].number > 0;
  }
  std::vector<float> zero(static_cast<size_t>(env->nslot()) * env->act_dim(), 0.f);
  env->step(zero);
  const auto st = env->take_stats();
  INFO(full << " of 256 reset states fill the " << m->narena << "-byte arena; " << st.faults
            << " slots faulted on the first step");
  CHECK(full == 0);
  CHECK(st.faults == 0);
}

// Every task: no object starts more than 5 mm inside a hand (at the original's start heights
// catch_over2underarm's egg started 13 mm inside the upright fingertips and left at about 1 m/s;
// with the 1 cm position noise the other eggs started up to ~16 mm in the palm).
TEST_CASE("objects do not start inside a hand", "[tasks][reset]") {
  for (const auto& f : task_facts()) {
    INFO("task " << f.id);
    auto env = make_env(f.id, 64, 3);
    const mjModel* m = env->model().mj();
    std::vector<int> object_bodies;
    for (int i = 0; i < f.nobj; ++i) object_bodies.push_back(object_of(*env, object_name(f.nobj, i)).body);
    double deepest = 0;
    for (int s = 0; s < env->nslot(); ++s) {
      const mjData* d = env->batch().data(s);
      for (int c = 0; c < d->ncon; ++c) {
        const int b1 = m->geom_bodyid[d->contact[c].geom1], b2 = m->geom_bodyid[d->contact[c].geom2];
        const bool o1 = std::count(object_bodies.begin(), object_bodies.end(), b1) > 0;
        const bool o2 = std::count(object_bodies.begin(), object_bodies.end(), b2) > 0;
        if (o1 != o2) deepest = std::min(deepest, d->contact[c].dist);
      }
    }
    INFO("deepest object-hand penetration at reset: " << -deepest * 1000 << " mm");
    CHECK(deepest > -0.005);
  }
}

TEST_CASE("per-slot goal shifts move each slot's goal from its next reset, and stay",
          "[tasks][reset][goals]") {
  auto env = make_env("catch_underarm", 4, 31, 1);
  const tasks::Slice* pose = env->spec().obs.find("goal.pose");
  REQUIRE(pose);
  REQUIRE(env->spec().goal_shifts == 1);
  const int od = env->obs_dim();
  auto goal = [&](int s) {
    std::vector<double> g;
    for (int k = 0; k < 3; ++k) g.push_back(env->obs[s * od + pose->start + k]);
    return g;
  };
  const std::vector<double> before = goal(1);
  // slots 1 and 3 get their own shifts; nothing moves until a reset
  env->set_goal_shifts({1, 3}, {0.05, -0.02, 0.01, -0.04, 0.0, 0.03});
  CHECK(goal(1) == before);
  env->reset();
  for (int round = 0; round < 2; ++round) {  // and they stay over later episodes
    CHECK(goal(1)[0] == Approx(before[0] + 0.05).margin(1e-5));
    CHECK(goal(1)[1] == Approx(before[1] - 0.02).margin(1e-5));
    CHECK(goal(1)[2] == Approx(before[2] + 0.01).margin(1e-5));
    CHECK(goal(3)[0] == Approx(before[0] - 0.04).margin(1e-5));
    CHECK(goal(3)[2] == Approx(before[2] + 0.03).margin(1e-5));
    CHECK(goal(0) == before);
    CHECK(goal(2) == before);
    env->reset();
  }
  // bad input names the task and the problem, and changes nothing
  auto message = [&](const std::vector<int>& slots, const std::vector<double>& v) {
    try {
      env->set_goal_shifts(slots, v);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  CHECK_THAT(message({1}, {0.1, 0.2}), Catch::Contains("catch_underarm") &&
                                           Catch::Contains("expected 3 values per slot") &&
                                           Catch::Contains("got 2"));
  CHECK_THAT(message({0, 4}, std::vector<double>(6, 0.0)),
             Catch::Contains("slot 4 is outside 0..3"));
  CHECK_THAT(message({0}, {0.0, NAN, 0.0}), Catch::Contains("non-finite"));
  env->reset();
  CHECK(goal(0) == before);
  auto door = make_env("door_open_outward", 2, 31, 1);
  try {
    door->set_goal_shifts({0}, {0, 0, 0});
    FAIL("accepted");
  } catch (const Error& e) {
    CHECK_THAT(e.what(), Catch::Contains("door_open_outward") &&
                             Catch::Contains("takes no per-slot goal"));
  }
}
