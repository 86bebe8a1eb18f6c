// sim/scene (and sim/model): the generated MJCF compiles in MuJoCo, its joints, ranges and
// actuators are the paper's, the left hand is the mirror image of the right one, the distal
// joints follow the middle ones, and the free base moves along the world axes.
#include "sim/scene.h"

#include <cmath>
#include <map>

#include <catch2/catch.hpp>
#include <mujoco/mujoco.h>

#include "sim/batch.h"
#include "tests/fixture.h"
#include "tests/paper_table.h"

using namespace bidex;
using namespace bidex::sim;
using bidex::test::kDeg;
using bidex::test::kPaperJoints;
using bidex::test::physics;
using bidex::test::shadow;

namespace {

struct MjDataPtr {
  explicit MjDataPtr(const mjModel* m) : d(mj_makeData(m)) { REQUIRE(d != nullptr); }
  ~MjDataPtr() { mj_deleteData(d); }
  mjData* d;
};

std::string name_of(const mjModel* m, mjtObj type, int id) {
  const char* n = mj_id2name(m, type, id);
  return n ? n : "";
}

SimModel one_hand(Side side, Base base) {
  SceneBuilder sb(physics());
  sb.add_hand(shadow(), {side, Pose::rpy({0, 0, 0.5}, 0, 0, 0), base});
  return sb.build(std::string(side_name(side)) + "_hand");
}

// Position of a world point in the frame of body `b` (d after kinematics).
std::array<double, 3> in_frame(const mjData* d, int b, const double* world) {
  const double* R = d->xmat + 9 * b;  // row-major body-to-world rotation
  const double* p = d->xpos + 3 * b;
  double v[3] = {world[0] - p[0], world[1] - p[1], world[2] - p[2]};
  return {R[0] * v[0] + R[3] * v[1] + R[6] * v[2], R[1] * v[0] + R[4] * v[1] + R[7] * v[2],
          R[2] * v[0] + R[5] * v[1] + R[8] * v[2]};
}

// Rotation of a frame (row-major 3x3 `Rw`, world) relative to body `b`: R_b^T R_w.
std::array<double, 9> rot_in_frame(const mjData* d, int b, const double* Rw) {
  const double* R = d->xmat + 9 * b;
  std::array<double, 9> out{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) out[3 * i + j] += R[3 * k + i] * Rw[3 * k + j];
  return out;
}

}  // namespace

TEST_CASE("the generated model compiles for each hand and base", "[sim][scene]") {
  const int njoint = 24, nact = 20, ntip = 5;
  for (Side side : {Side::kRight, Side::kLeft}) {
    for (Base base : {Base::kFixed, Base::kFree}) {
      bool free = base == Base::kFree;
      INFO(side_name(side) << (free ? " free" : " fixed"));
      SimModel m = one_hand(side, base);
      const mjModel* mj = m.mj();
      REQUIRE(mj != nullptr);
      // a hinge per paper joint; a free base adds 3 slides and a ball
      CHECK(mj->njnt == njoint + (free ? 4 : 0));
      CHECK(m.nq() == njoint + (free ? 7 : 0));
      CHECK(m.nv() == njoint + (free ? 6 : 0));
      CHECK(m.nu() == nact);
      CHECK(mj->neq == 4);
      CHECK(m.nsensordata() == ntip * 6);
      CHECK(m.nwrench() == 6);
      REQUIRE(m.hands().size() == 1);
      const HandIndex& h = m.hands()[0];
      CHECK(h.side == side);
      CHECK(h.prefix == hand_prefix(side));
      CHECK(h.free_base == free);
      CHECK(m.hand(side) == &h);
      CHECK(m.hand(side == Side::kRight ? Side::kLeft : Side::kRight) == nullptr);
      CHECK(name_of(mj, mjOBJ_BODY, h.root_body) == h.prefix + "forearm");
      CHECK(h.bodies.size() == shadow().bodies.size());
      CHECK(h.joints.size() == 24);
      CHECK(h.actuators.size() == 20);
      CHECK(h.tip_sites.size() == 5);
      if (free) {
        CHECK(h.base_qpos_adr >= 0);
        CHECK(mj->jnt_type[mj_name2id(mj, mjOBJ_JOINT, (h.prefix + "base_rot").c_str())] ==
              mjJNT_BALL);
      } else {
        CHECK(h.base_qpos_adr == -1);
      }
      // the in-memory MJCF text is what was compiled: compiling it again gives the same sizes
      mjModel* again = compile_mjcf(m.mjcf(), "again");
      CHECK(again->nq == mj->nq);
      CHECK(again->nbody == mj->nbody);
      mj_deleteModel(again);
      // a forward pass of the initial state is finite
      MjDataPtr d(mj);
      mj_forward(mj, d.d);
      for (int i = 0; i < mj->nbody * 3; ++i) REQUIRE(std::isfinite(d.d->xpos[i]));
      CHECK(m.data_bytes() > sizeof(mjData));
    }
  }
}

TEST_CASE("both hands and the two-hand scene compile", "[sim][scene]") {
  SECTION("both hands, fixed and free") {
    for (Base base : {Base::kFixed, Base::kFree}) {
      SceneBuilder sb(physics());
      sb.add_hand(shadow(), {Side::kRight, Pose::rpy({0, 0, 0.5}, 0, 0, 0), base});
      sb.add_hand(shadow(), {Side::kLeft, Pose::rpy({0, -1, 0.5}, 0, 0, M_PI), base});
      SimModel m = sb.build("both");
      int extra = base == Base::kFree ? 7 : 0;
      CHECK(m.nq() == 2 * (24 + extra));
      CHECK(m.nu() == 40);
      CHECK(m.mj()->neq == 8);
      CHECK(m.nwrench() == 12);
      REQUIRE(m.hand(Side::kRight) != nullptr);
      REQUIRE(m.hand(Side::kLeft) != nullptr);
      CHECK(m.hand(Side::kLeft)->prefix == "lh_");
    }
  }
  SECTION("two_hand_scene: two free hands and an egg") {
    const SimModel& m = bidex::test::two_hand_model();
    CHECK(m.nq() == 2 * 31 + 7);
    CHECK(m.nv() == 2 * 30 + 6);
    CHECK(m.nu() == 40);
    CHECK(m.nsensordata() == 60);
    REQUIRE(m.object("object") != nullptr);
    CHECK(m.object("object")->qpos_adr >= 0);
    CHECK(m.object("nothing") == nullptr);
    const mjModel* mj = m.mj();
    int egg = m.object("object")->body;
    CHECK(mj->body_mass[egg] == Approx(0.075));
    CHECK(m.hand(Side::kRight)->free_base);
    CHECK(m.hand(Side::kLeft)->free_base);
    // the physics options reach the compiled model
    CHECK(mj->opt.timestep == Approx(physics().timestep));
    CHECK(mj->opt.iterations == physics().iterations);
    // gravity compensation: every hand body carries its whole weight (gravcomp 1), the egg none
    for (Side side : {Side::kRight, Side::kLeft})
      for (int b : m.hand(side)->bodies) CHECK(mj->body_gravcomp[b] == 1.0);
    CHECK(mj->body_gravcomp[egg] == 0.0);
  }
}

TEST_CASE("compiled joints, ranges and actuators match the paper table", "[sim][scene]") {
  const SimModel& model = bidex::test::fixed_hands_model();
  const mjModel* m = model.mj();
  for (Side side : {Side::kRight, Side::kLeft}) {
    const HandIndex* h = model.hand(side);
    REQUIRE(h != nullptr);
    const std::string pre = hand_prefix(side);
    INFO("hand " << pre);
    REQUIRE(h->joints.size() == kPaperJoints.size());

    int act_k = 0;      // position in the hand's actuator list
    int prev_act = -1;  // actuator ids increase in tree order
    for (size_t i = 0; i < kPaperJoints.size(); ++i) {
      const auto& want = kPaperJoints[i];
      INFO("joint " << want.name);
      int jid = mj_name2id(m, mjOBJ_JOINT, (pre + want.name).c_str());
      REQUIRE(jid >= 0);
      // tree order: the hand's joints are consecutive in the model, in the paper's order
      CHECK(jid == h->joints[0] + static_cast<int>(i));
      CHECK(h->joints[i] == jid);
      CHECK(h->joint_names[i] == want.name);
      CHECK(h->qpos_adr[i] == m->jnt_qposadr[jid]);
      CHECK(m->jnt_qposadr[jid] == m->jnt_qposadr[h->joints[0]] + static_cast<int>(i));
      CHECK(m->jnt_type[jid] == mjJNT_HINGE);
      CHECK(m->jnt_limited[jid]);
      CHECK(m->jnt_range[2 * jid] == Approx(want.min_deg * kDeg).margin(1e-9));
      CHECK(m->jnt_range[2 * jid + 1] == Approx(want.max_deg * kDeg).margin(1e-9));

      int aid = mj_name2id(m, mjOBJ_ACTUATOR, (pre + want.name).c_str());
      if (!want.actuated) {
        CHECK(aid == -1);
        // no actuator of the model drives this joint
        for (int a = 0; a < m->nu; ++a) CHECK(m->actuator_trnid[2 * a] != jid);
        continue;
      }
      REQUIRE(aid >= 0);
      REQUIRE(act_k < static_cast<int>(h->actuators.size()));
      CHECK(h->actuators[act_k] == aid);
      CHECK(h->actuated[act_k] == static_cast<int>(i));
      CHECK(aid > prev_act);
      prev_act = aid;
      ++act_k;
      CHECK(m->actuator_trntype[aid] == mjTRN_JOINT);
      CHECK(m->actuator_trnid[2 * aid] == jid);
      // a position servo: force = kp (ctrl - q)
      CHECK(m->actuator_gaintype[aid] == mjGAIN_FIXED);
      CHECK(m->actuator_biastype[aid] == mjBIAS_AFFINE);
      CHECK(m->actuator_gainprm[aid * mjNGAIN] > 0);
      CHECK(m->actuator_biasprm[aid * mjNBIAS + 1] == -m->actuator_gainprm[aid * mjNGAIN]);
      // targets limited to the joint range, force limited to the paper's value
      CHECK(m->actuator_ctrllimited[aid]);
      CHECK(m->actuator_ctrlrange[2 * aid] == Approx(m->jnt_range[2 * jid]).margin(1e-12));
      CHECK(m->actuator_ctrlrange[2 * aid + 1] == Approx(m->jnt_range[2 * jid + 1]).margin(1e-12));
      CHECK(m->actuator_forcelimited[aid]);
      CHECK(m->actuator_forcerange[2 * aid] == Approx(-want.force_limit).margin(1e-12));
      CHECK(m->actuator_forcerange[2 * aid + 1] == Approx(want.force_limit).margin(1e-12));
    }
    CHECK(act_k == 20);
    CHECK(h->actuators.size() == 20);
  }
  // the right hand's 20 actuators come first, then the left hand's
  CHECK(model.hand(Side::kRight)->actuators.front() == 0);
  CHECK(model.hand(Side::kLeft)->actuators.front() == 20);

  // the couplings: 8 joint equalities, distal = 1 * middle
  REQUIRE(m->neq == 8);
  for (int e = 0; e < m->neq; ++e) {
    CHECK(m->eq_type[e] == mjEQ_JOINT);
    std::string j1 = name_of(m, mjOBJ_JOINT, m->eq_obj1id[e]);
    std::string j2 = name_of(m, mjOBJ_JOINT, m->eq_obj2id[e]);
    INFO(j1 << " follows " << j2);
    REQUIRE(j1.size() == 6);
    CHECK(j1.substr(0, 3) == j2.substr(0, 3));    // same hand
    CHECK(j1.substr(3, 2) == j2.substr(3, 2));    // same finger
    CHECK(j1.back() == '1');
    CHECK(j2.back() == '2');
    CHECK(m->eq_data[e * mjNEQDATA + 0] == 0);
    CHECK(m->eq_data[e * mjNEQDATA + 1] == 1.0);
  }
}

TEST_CASE("the left hand is the mirror image of the right hand", "[sim][scene]") {
  // both hands at one (arbitrary) mount pose, passing through each other
  Pose pose = Pose::rpy({0.1, -0.2, 0.6}, 0.3, -0.4, 0.7);
  SceneBuilder sb(physics());
  sb.set_hand_hand_contacts(false);
  sb.add_hand(shadow(), {Side::kRight, pose, Base::kFixed});
  sb.add_hand(shadow(), {Side::kLeft, pose, Base::kFixed});
  SimModel model = sb.build("mirror");
  const mjModel* m = model.mj();
  const HandIndex& r = *model.hand(Side::kRight);
  const HandIndex& l = *model.hand(Side::kLeft);
  MjDataPtr data(m);
  mjData* d = data.d;

  // the same random angles, inside each joint's range, on both hands
  std::mt19937_64 rng(12345);
  for (int trial = 0; trial < 3; ++trial) {
    INFO("trial " << trial);
    for (size_t i = 0; i < r.joints.size(); ++i) {
      double lo = m->jnt_range[2 * r.joints[i]], hi = m->jnt_range[2 * r.joints[i] + 1];
      double q = trial == 0 ? 0.0 : std::uniform_real_distribution<double>(lo, hi)(rng);
      d->qpos[r.qpos_adr[i]] = q;
      d->qpos[l.qpos_adr[i]] = q;
    }
    mj_kinematics(m, d);

    // the two forearms coincide
    for (int k = 0; k < 3; ++k) CHECK(d->xpos[3 * r.root_body + k] == d->xpos[3 * l.root_body + k]);
    for (int k = 0; k < 9; ++k) CHECK(d->xmat[9 * r.root_body + k] == d->xmat[9 * l.root_body + k]);

    // M = diag(-1, 1, 1) in the hand (forearm) frame: p_left = M p_right, R_left = M R_right M
    const int root = r.root_body;
    auto check_point = [&](const std::string& what, const double* pr, const double* pl) {
      auto a = in_frame(d, root, pr);
      auto b = in_frame(d, root, pl);
      INFO(what << ": right (" << a[0] << ", " << a[1] << ", " << a[2] << "), left (" << b[0]
                << ", " << b[1] << ", " << b[2] << ")");
      CHECK(b[0] == Approx(-a[0]).margin(1e-9));
      CHECK(b[1] == Approx(a[1]).margin(1e-9));
      CHECK(b[2] == Approx(a[2]).margin(1e-9));
    };
    auto check_rot = [&](const std::string& what, const double* Rr, const double* Rl) {
      auto a = rot_in_frame(d, root, Rr);
      auto b = rot_in_frame(d, root, Rl);
      INFO(what);
      const double s[3] = {-1, 1, 1};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) CHECK(b[3 * i + j] == Approx(s[i] * s[j] * a[3 * i + j]).margin(1e-9));
    };
    REQUIRE(r.bodies.size() == l.bodies.size());
    for (size_t i = 0; i < r.bodies.size(); ++i) {
      std::string n = name_of(m, mjOBJ_BODY, r.bodies[i]);
      REQUIRE(name_of(m, mjOBJ_BODY, l.bodies[i]) == "lh_" + n.substr(3));
      check_point(n, d->xpos + 3 * r.bodies[i], d->xpos + 3 * l.bodies[i]);
      check_point(n + " com", d->xipos + 3 * r.bodies[i], d->xipos + 3 * l.bodies[i]);
      check_rot(n, d->xmat + 9 * r.bodies[i], d->xmat + 9 * l.bodies[i]);
    }
    // every geom and site too (capsule end points follow from centre and orientation)
    int ngeom_r = 0;
    for (int g = 0; g < m->ngeom; ++g) {
      std::string n = name_of(m, mjOBJ_GEOM, g);
      if (n.rfind("rh_", 0) != 0) continue;
      int gl = mj_name2id(m, mjOBJ_GEOM, ("lh_" + n.substr(3)).c_str());
      REQUIRE(gl >= 0);
      ++ngeom_r;
      check_point(n, d->geom_xpos + 3 * g, d->geom_xpos + 3 * gl);
      CHECK(m->geom_size[3 * gl] == m->geom_size[3 * g]);
      CHECK(m->geom_size[3 * gl + 1] == m->geom_size[3 * g + 1]);
    }
    CHECK(ngeom_r >= 24);
    for (size_t i = 0; i < r.tip_sites.size(); ++i)
      check_point(name_of(m, mjOBJ_SITE, r.tip_sites[i]), d->site_xpos + 3 * r.tip_sites[i],
                  d->site_xpos + 3 * l.tip_sites[i]);
    // joint axes are pseudo-vectors: axis_left = -M axis_right
    for (size_t i = 0; i < r.joints.size(); ++i) {
      INFO(r.joint_names[i]);
      const double* R = d->xmat + 9 * root;
      auto local = [&](const double* v) {
        return std::array<double, 3>{R[0] * v[0] + R[3] * v[1] + R[6] * v[2],
                                     R[1] * v[0] + R[4] * v[1] + R[7] * v[2],
                                     R[2] * v[0] + R[5] * v[1] + R[8] * v[2]};
      };
      auto ar = local(d->xaxis + 3 * r.joints[i]);
      auto al = local(d->xaxis + 3 * l.joints[i]);
      CHECK(al[0] == Approx(ar[0]).margin(1e-9));
      CHECK(al[1] == Approx(-ar[1]).margin(1e-9));
      CHECK(al[2] == Approx(-ar[2]).margin(1e-9));
    }
  }
  // the right hand is not symmetric itself (the check above is not trivially true): its thumb
  // sits on one side of the hand frame
  mj_resetData(m, d);
  mj_kinematics(m, d);
  int th = mj_name2id(m, mjOBJ_BODY, "rh_thbase");
  CHECK(std::abs(in_frame(d, r.root_body, d->xpos + 3 * th)[0]) > 0.01);
}

TEST_CASE("flexion is positive towards the palm on both hands", "[sim][scene]") {
  const SimModel& model = bidex::test::fixed_hands_model();
  const mjModel* m = model.mj();
  MjDataPtr data(m);
  mjData* d = data.d;
  // palm side: the hand frame's -y (where the thumb base sits); both hands are mounted palm up
  const char* fingers[4] = {"FF", "MF", "RF", "LF"};
  const char* tips[4] = {"fftip", "mftip", "rftip", "lftip"};
  for (Side side : {Side::kRight, Side::kLeft}) {
    const HandIndex& h = *model.hand(side);
    const std::string pre = h.prefix;
    mj_resetData(m, d);
    mj_kinematics(m, d);
    int th = mj_name2id(m, mjOBJ_BODY, (pre + "thbase").c_str());
    int palm = mj_name2id(m, mjOBJ_BODY, (pre + "palm").c_str());
    CHECK(in_frame(d, palm, d->xpos + 3 * th)[1] < 0);  // the thumb sits on the palm side
    for (int f = 0; f < 4; ++f) {
      for (const char* level : {"3", "2", "1"}) {
        std::string jn = std::string(fingers[f]) + level;
        INFO(pre << jn);
        int jid = mj_name2id(m, mjOBJ_JOINT, (pre + jn).c_str());
        int site = mj_name2id(m, mjOBJ_SITE, (pre + tips[f]).c_str());
        REQUIRE(jid >= 0);
        REQUIRE(site >= 0);
        mj_resetData(m, d);
        mj_kinematics(m, d);
        auto tip0 = in_frame(d, h.root_body, d->site_xpos + 3 * site);
        double z0 = d->site_xpos[3 * site + 2];
        d->qpos[m->jnt_qposadr[jid]] = 1.0;  // +1 rad
        mj_kinematics(m, d);
        auto tip1 = in_frame(d, h.root_body, d->site_xpos + 3 * site);
        double z1 = d->site_xpos[3 * site + 2];
        CHECK(tip1[1] < tip0[1] - 0.01);  // towards the palm side of the hand frame
        CHECK(z1 > z0 + 0.01);            // up, since the palm faces up in this scene
        CHECK(tip1[0] == Approx(tip0[0]).margin(1e-9));  // no sideways motion
      }
    }
  }
}

TEST_CASE("coupled distal joints follow the middle joints within 1e-3 rad", "[sim][scene][coupling]") {
  const SimModel& model = bidex::test::fixed_hands_model();
  const mjModel* m = model.mj();
  SimBatch batch(model, 1, {1, 7});
  const double dt = model.physics().control_dt();
  const double up_s = 0.75, down_s = 0.75, hold_s = 0.25;
  const int nstep = static_cast<int>(std::lround((up_s + down_s + hold_s) / dt));
  const char* fingers[4] = {"FF", "MF", "RF", "LF"};

  struct Pair {
    std::string name;
    int act, q1, q2;  // actuator of the middle joint, qpos of distal and middle
  };
  std::vector<Pair> pairs;
  for (Side side : {Side::kRight, Side::kLeft}) {
    const std::string pre = hand_prefix(side);
    for (const char* f : fingers) {
      Pair p;
      p.name = pre + f;
      p.act = mj_name2id(m, mjOBJ_ACTUATOR, (pre + f + "2").c_str());
      int j1 = mj_name2id(m, mjOBJ_JOINT, (pre + f + "1").c_str());
      int j2 = mj_name2id(m, mjOBJ_JOINT, (pre + f + "2").c_str());
      REQUIRE(p.act >= 0);
      REQUIRE(j1 >= 0);
      REQUIRE(j2 >= 0);
      p.q1 = m->jnt_qposadr[j1];
      p.q2 = m->jnt_qposadr[j2];
      pairs.push_back(p);
    }
  }

  double worst = 0, worst_t = 0;
  std::string worst_name;
  std::vector<double> peak(pairs.size(), 0.0);
  const double top = 90 * kDeg;
  for (int k = 1; k <= nstep; ++k) {
    double t = k * dt;
    double target = t < up_s ? top * t / up_s
                    : t < up_s + down_s ? top * (1 - (t - up_s) / down_s)
                                        : 0.0;
    auto v = batch.slot(0);
    for (auto& p : pairs) v.ctrl[p.act] = target;
    step(model, batch);
    REQUIRE(batch.fault[0] == kFaultNone);
    for (size_t i = 0; i < pairs.size(); ++i) {
      double q1 = v.qpos[pairs[i].q1], q2 = v.qpos[pairs[i].q2];
      peak[i] = std::max(peak[i], q2);
      double err = std::abs(q1 - q2);
      if (err > worst) {
        worst = err;
        worst_t = t;
        worst_name = pairs[i].name;
      }
    }
  }
  // the sweep really moved every middle joint well into its range
  for (size_t i = 0; i < pairs.size(); ++i) {
    INFO(pairs[i].name << "2 peak " << peak[i] / kDeg << " deg");
    CHECK(peak[i] > 45 * kDeg);
  }
  INFO("largest |q1 - q2| = " << worst << " rad (" << worst_name << " at t = " << worst_t
                              << " s) over " << nstep << " control steps of " << dt << " s");
  CHECK(worst <= 1e-3);
}

TEST_CASE("a free base moves along the world axes and carries no weight", "[sim][scene]") {
  const SimModel& model = bidex::test::two_hand_model();
  for (Side side : {Side::kRight, Side::kLeft}) {
    const HandIndex& h = *model.hand(side);
    const int hi = side == Side::kRight ? 0 : 1;
    for (int axis = 0; axis < 3; ++axis) {
      INFO(side_name(side) << " hand, force along world axis " << axis);
      SimBatch batch(model, 1, {1, 3});
      double p0[3];
      std::copy_n(batch.xpos.data() + 3 * h.root_body, 3, p0);
      for (int k = 0; k < 30; ++k) {
        std::fill(batch.base_wrench.begin(), batch.base_wrench.end(), 0.0);
        batch.base_wrench[hi * 6 + axis] = 50.0;  // N, world frame
        step(model, batch);
        REQUIRE(batch.fault[0] == kFaultNone);
      }
      const double* p1 = batch.xpos.data() + 3 * h.root_body;
      for (int k = 0; k < 3; ++k) {
        double moved = p1[k] - p0[k];
        if (k == axis) CHECK(moved > 0.005);
        else CHECK(std::abs(moved) < 0.1 * (p1[axis] - p0[axis]));
      }
      // the slides' qpos follow the world displacement
      CHECK(batch.qpos[h.base_qpos_adr + axis] == Approx(p1[axis] - p0[axis]).margin(1e-6));
      // the force acts at the base pivot: a push translates without turning the hand (applied
      // at the forearm's centre of mass instead, this push turned it at about 0.3 rad/s); the
      // fingers swinging as the hand accelerates leave a trace (4e-5 rad/s); the right hand also
      // catches the falling egg, which tips it a little
      const double turn_limit = side == Side::kLeft ? 1e-3 : 0.05;
      for (int k = 3; k < 6; ++k)
        CHECK(std::abs(batch.qvel[h.base_dof_adr + k]) < turn_limit);
    }
  }
}

TEST_CASE("with no input the gravity-free hands stay put while the egg falls", "[sim][scene]") {
  const SimModel& model = bidex::test::two_hand_model();
  SimBatch batch(model, 1, {1, 3});
  const int egg_dof = model.object("object")->dof_adr;
  std::vector<double> x0 = batch.xpos;
  step(model, batch);
  CHECK(batch.qvel[egg_dof + 2] < -0.1);  // gravity acts on the egg (about -g * 1/60 s)
  for (int k = 1; k < 60; ++k) step(model, batch);
  REQUIRE(batch.fault[0] == kFaultNone);
  // a hand carrying its weight (about 5.5 kg) on the base damping (500 N s/m) would sink about
  // 0.1 m in this second; the right hand only carries the egg (0.74 N: about 1.5 mm)
  for (Side side : {Side::kRight, Side::kLeft}) {
    int b = model.hand(side)->root_body;
    double tol = side == Side::kRight ? 5e-3 : 1e-4;
    for (int k = 0; k < 3; ++k) {
      INFO(side_name(side) << " hand, axis " << k << ": moved " << batch.xpos[3 * b + k] - x0[3 * b + k]);
      CHECK(std::abs(batch.xpos[3 * b + k] - x0[3 * b + k]) < tol);
    }
  }
}

TEST_CASE("collision bits: one hand's parts pass through each other except listed pairs",
          "[sim][scene]") {
  for (bool hand_hand : {true, false}) {
    INFO("hand-hand contacts " << hand_hand);
    SceneBuilder sb(physics());
    sb.set_hand_hand_contacts(hand_hand);
    sb.add_hand(shadow(), {Side::kRight, Pose::rpy({0, 0, 0.5}, 0, 0, 0), Base::kFixed});
    sb.add_hand(shadow(), {Side::kLeft, Pose::rpy({0, -1, 0.5}, 0, 0, M_PI), Base::kFixed});
    SimModel model = sb.build("bits");
    const mjModel* m = model.mj();
    auto collide = [&](int a, int b) {
      return (m->geom_contype[a] & m->geom_conaffinity[b]) ||
             (m->geom_contype[b] & m->geom_conaffinity[a]);
    };
    std::vector<int> rh, lh;
    int floor = mj_name2id(m, mjOBJ_GEOM, "floor");
    REQUIRE(floor >= 0);
    for (int g = 0; g < m->ngeom; ++g) {
      std::string n = name_of(m, mjOBJ_GEOM, g);
      if (n.rfind("rh_", 0) == 0) rh.push_back(g);
      if (n.rfind("lh_", 0) == 0) lh.push_back(g);
    }
    REQUIRE(rh.size() == lh.size());
    for (int a : rh) {
      CHECK(collide(a, floor));
      for (int b : rh) CHECK_FALSE(collide(a, b));
      for (int b : lh) CHECK(collide(a, b) == hand_hand);
    }
    // the self-contact pairs: one pair per geom pair of the spec's body pairs, per hand
    int npair = 0;
    for (auto& pr : shadow().self_contacts)
      npair += static_cast<int>(shadow().body(pr[0])->geoms.size() *
                                shadow().body(pr[1])->geoms.size());
    CHECK(m->npair == 2 * npair);
  }
}

TEST_CASE("scene errors: a second hand per side, MJCF MuJoCo refuses", "[sim][scene]") {
  SECTION("two right hands") {
    SceneBuilder sb(physics());
    sb.add_hand(shadow(), {Side::kRight, Pose{}, Base::kFixed});
    auto e = bidex::test::config_error(
        [&] { sb.add_hand(shadow(), {Side::kRight, Pose{}, Base::kFree}); });
    CHECK(e.key() == "scene.hands");
    CHECK(e.actual().find("right") != std::string::npos);
  }
  SECTION("two objects of one name") {
    SceneBuilder sb(physics());
    ObjectSpec o;
    o.name = "cube";
    sb.add_object(o);
    CHECK_THROWS_AS(sb.add_object(o), ConfigError);
  }
  SECTION("an object MuJoCo cannot compile is a ModelError with MuJoCo's message") {
    SceneBuilder sb(physics());
    ObjectSpec o;
    o.name = "blob";
    o.shape = ObjectSpec::Shape::kMjcf;
    o.mjcf_body = "<geom type=\"teapot\" size=\"1\"/>";
    sb.add_object(o);
    try {
      sb.build("bad_scene");
      FAIL("no error");
    } catch (const ModelError& e) {
      std::string what = e.what();
      INFO(what);
      CHECK(what.find("bad_scene") != std::string::npos);
      CHECK(what.find("teapot") != std::string::npos);
    }
  }
  SECTION("compile_mjcf of text that is not MJCF") {
    CHECK_THROWS_AS(compile_mjcf("<mujoco><nonsense/></mujoco>", "junk"), ModelError);
  }
}

TEST_CASE("Pose::rpy composes yaw, pitch and roll", "[sim][scene]") {
  Pose p = Pose::rpy({1, 2, 3}, 0, 0, M_PI / 2);
  CHECK(p.pos == Vec3{1, 2, 3});
  CHECK(p.quat[0] == Approx(std::sqrt(0.5)));
  CHECK(p.quat[3] == Approx(std::sqrt(0.5)));
  // R = Rz(yaw) Ry(pitch) Rx(roll): compare with MuJoCo's quaternion product
  double r = 0.3, pi = -0.2, y = 1.1;
  Pose q = Pose::rpy({0, 0, 0}, r, pi, y);
  double qx[4] = {std::cos(r / 2), std::sin(r / 2), 0, 0};
  double qy[4] = {std::cos(pi / 2), 0, std::sin(pi / 2), 0};
  double qz[4] = {std::cos(y / 2), 0, 0, std::sin(y / 2)};
  double t[4], want[4];
  mju_mulQuat(t, qz, qy);
  mju_mulQuat(want, t, qx);
  for (int k = 0; k < 4; ++k) CHECK(q.quat[k] == Approx(want[k]).margin(1e-12));
}
