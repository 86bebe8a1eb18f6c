#include "bench/physics_study.h"
#include "bench/sim_bench.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <optional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/progress.h"
#include "sim/batch.h"
#include "sim/scene.h"

namespace bidex::bench {

using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {


bool is_wrist(const std::string& joint) { return joint.rfind("WR", 0) == 0; }

const sim::HandIndex& hand_of(const sim::SimModel& model, sim::Side side) {
  const sim::HandIndex* h = model.hand(side);
  if (!h) throw ModelError(std::string("the scene has no ") + sim::side_name(side) + " hand");
  return *h;
}

int hand_number(const sim::SimModel& model, sim::Side side) {
  const auto& hands = model.hands();
  for (size_t h = 0; h < hands.size(); ++h)
    if (hands[h].side == side) return static_cast<int>(h);
  throw ModelError(std::string("the scene has no ") + sim::side_name(side) + " hand");
}

int joint_qadr(const sim::HandIndex& h, const std::string& name) {
  for (size_t k = 0; k < h.joint_names.size(); ++k)
    if (h.joint_names[k] == name) return h.qpos_adr[k];
  throw ModelError("hand " + h.prefix + " has no joint " + name);
}

int actuator_of(const sim::HandIndex& h, const std::string& name) {
  for (size_t a = 0; a < h.actuated.size(); ++a)
    if (h.joint_names[h.actuated[a]] == name) return h.actuators[a];
  throw ModelError("hand " + h.prefix + " has no actuator for joint " + name);
}

struct CouplingIdx {
  int hand;  // index into model.hands()
  int qa, qb;
  double ratio;
};

std::vector<CouplingIdx> coupling_index(const sim::SimModel& model, const sim::HandSpec& spec) {
  std::vector<CouplingIdx> out;
  const auto& hands = model.hands();
  for (size_t h = 0; h < hands.size(); ++h)
    for (auto& c : spec.couplings)
      out.push_back({static_cast<int>(h), joint_qadr(hands[h], c.joint),
                     joint_qadr(hands[h], c.follows), c.ratio});
  return out;
}

// One slot of a batch (initial state from sim::reset_slot), stepped at the physics rate with the
// same applied forces as sim::step: each free base's wrench (the hands' weight is gravcomp's).
struct World {
  const sim::SimModel& model;
  const mjModel* m;
  sim::SimBatch batch;
  mjData* d;
  std::vector<double> wrench;

  explicit World(const sim::SimModel& mdl)
      : model(mdl), m(mdl.mj()), batch(mdl, 1, {1, 1}), d(batch.data(0)),
        wrench(mdl.nwrench(), 0.0) {}

  // one physics step, of `with` where given (the model with other options, e.g. gravity)
  void step(const mjModel* with = nullptr) {
    sim::update_base_wrench(model, d, wrench.data());
    mj_step(with ? with : m, d);
  }
  double dt() const { return m->opt.timestep; }
  int substeps() const { return model.physics().substeps; }
  int steps_for(double seconds) const { return static_cast<int>(std::lround(seconds / dt())); }
  bool finite() const {
    for (int i = 0; i < m->nv; ++i)
      if (!std::isfinite(d->qvel[i])) return false;
    for (int i = 0; i < m->nq; ++i)
      if (!std::isfinite(d->qpos[i])) return false;
    return true;
  }
};

std::array<double, 3> vec3(const double* p) { return {p[0], p[1], p[2]}; }
double dist3(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
}
double norm3(const double* v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

// position of `p` in the frame of body `b` (R^T (p - x))
std::array<double, 3> in_body_frame(const mjData* d, int b, const double* p) {
  const double* x = d->xpos + 3 * b;
  const double* R = d->xmat + 9 * b;
  double r[3] = {p[0] - x[0], p[1] - x[1], p[2] - x[2]};
  return {R[0] * r[0] + R[3] * r[1] + R[6] * r[2], R[1] * r[0] + R[4] * r[1] + R[7] * r[2],
          R[2] * r[0] + R[5] * r[1] + R[8] * r[2]};
}

// rotation angle of a unit quaternion (w, x, y, z) relative to the identity
double quat_angle(const double* q) {
  double w = std::min(1.0, std::abs(q[0]));
  return 2.0 * std::acos(w);
}

double percentile(std::vector<float> v, double p) {
  if (v.empty()) return 0;
  size_t k = std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// MuJoCo keeps every constraint's time constant at least twice the timestep (REFSAFE), except
// with the discrete integrator: it evaluates the springs at the end of the step and caps only
// contact and limit rows whose spring the step cannot resolve (dt^2 k imp > 1, k = 1 / (dmax^2
// tc^2 zeta^2): at full impedance a time constant below dt / (zeta sqrt(dmax)), about dt), and
// leaves equality rows (the coupling) as they are.
double contact_floor(const sim::PhysicsOptions& p) {
  if (!p.refsafe) return 0;
  if (p.integrator != "discrete") return 2.0 * p.timestep;
  return p.timestep / (p.contact_solref[1] * std::sqrt(p.contact_solimp[1]));
}
double coupling_floor(const sim::PhysicsOptions& p) {
  return p.refsafe && p.integrator != "discrete" ? 2.0 * p.timestep : 0;
}
double effective_contact_timeconst(const sim::PhysicsOptions& p) {
  return std::max(p.contact_solref[0], contact_floor(p));
}
double effective_coupling_timeconst(const sim::PhysicsOptions& p) {
  return std::max(p.coupling_solref[0], coupling_floor(p));
}

json hand_json(const HandTuning& h) {
  return {{"finger_damping", h.finger_damping},
          {"finger_kp", h.finger_kp},
          {"frictionloss", h.frictionloss},
          {"base_damping_translation", h.base_translation},
          {"base_damping_rotation", h.base_rotation}};
}

bool same(const HandTuning& a, const HandTuning& b) { return hand_json(a) == hand_json(b); }
// the options as MuJoCo uses them: time constants below the integrator's floor raised to it
sim::PhysicsOptions effective(sim::PhysicsOptions p) {
  const double contact = effective_contact_timeconst(p), coupling = effective_coupling_timeconst(p);
  p.contact_solref[0] = contact;
  p.coupling_solref[0] = coupling;
  return p;
}
bool same(const sim::PhysicsOptions& a, const sim::PhysicsOptions& b) {
  return physics_json(effective(a)) == physics_json(effective(b));
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

}  // namespace

json physics_json(const sim::PhysicsOptions& p) {
  return {{"timestep", p.timestep},
          {"substeps", p.substeps},
          {"integrator", p.integrator},
          {"solver", p.solver},
          {"iterations", p.iterations},
          {"tolerance", p.tolerance},
          {"cone", p.cone},
          {"refsafe", p.refsafe},
          {"jacobian", p.jacobian},
          {"contact_solref", p.contact_solref},
          {"contact_solimp", p.contact_solimp},
          {"coupling_solref", p.coupling_solref},
          {"coupling_solimp", p.coupling_solimp},
          {"gravity_free_hands", p.gravity_free_hands},
          {"memory", p.memory},
          {"max_speed", p.max_speed}};
}

HandTuning hand_tuning(const sim::HandSpec& spec) {
  HandTuning t;
  const sim::JointSpec* ff3 = spec.joint("FF3");
  if (!ff3 || !ff3->actuator) throw ModelError("hand spec " + spec.file + " lacks actuated FF3");
  t.finger_damping = ff3->damping;
  t.finger_kp = ff3->actuator->kp;
  t.frictionloss = ff3->frictionloss;
  t.base_translation = spec.base.damping_translation;
  t.base_rotation = spec.base.damping_rotation;
  return t;
}

sim::HandSpec apply_tuning(sim::HandSpec spec, const HandTuning& t) {
  for (auto& b : spec.bodies) {
    if (!b.joint) continue;
    b.joint->frictionloss = t.frictionloss;
    if (is_wrist(b.joint->name)) continue;
    b.joint->damping = t.finger_damping;
    if (b.joint->actuator) b.joint->actuator->kp = t.finger_kp;
  }
  spec.base.damping_translation = t.base_translation;
  spec.base.damping_rotation = t.base_rotation;
  return spec;
}

std::vector<Candidate> study_candidates(const sim::PhysicsOptions& P, const HandTuning& H,
                                        const std::vector<std::string>& groups) {
  std::vector<Candidate> out;
  out.push_back({"reference", "reference", P, H});
  // the reference once more: its cost ratio to itself shows the timing noise of this run
  out.push_back({"reference", "reference (repeat)", P, H, /*cost_only=*/true});
  auto want = [&](const char* g) {
    return groups.empty() || std::find(groups.begin(), groups.end(), g) != groups.end();
  };
  auto add = [&](const char* group, const std::string& name, const sim::PhysicsOptions& p,
                 const HandTuning& h) {
    for (auto& c : out)
      if (same(p, c.physics) && same(h, c.hand)) return;  // measured already
    out.push_back({group, name, p, h});
  };
  const double control_dt = P.control_dt();

  if (want("timestep")) {
    for (int n : {2, 4, 6, 8, 10}) {
      sim::PhysicsOptions p = P;
      p.substeps = n;
      p.timestep = control_dt / n;
      add("timestep", "substeps=" + std::to_string(n) + " (dt " + fmt("%.2f", p.timestep * 1e3) +
                          " ms)", p, H);
    }
    // the same with contacts and couplings as stiff as REFSAFE lets them be (time constant 2 dt)
    for (int n : {4, 6, 8, 10}) {
      sim::PhysicsOptions p = P;
      p.substeps = n;
      p.timestep = control_dt / n;
      p.contact_solref[0] = 2 * p.timestep;
      p.coupling_solref[0] = 2 * p.timestep;
      add("timestep", "substeps=" + std::to_string(n) + ", solrefs 2 dt", p, H);
    }
  }
  if (want("integrator")) {
    // each integrator at 8, 6, 4 and 2 substeps, with contacts and couplings from the stiffest the
    // integrator allows at that timestep (its floor) up to the reference's time constant, and
    // the floor with 2 dt beside it (where they differ); then, at the cheapest steps, the
    // elliptic cone and the solver's iteration cap
    for (const char* integ : {"Euler", "implicitfast", "discrete"}) {
      for (int n : {8, 6, 4, 2}) {
        sim::PhysicsOptions p = P;
        p.integrator = integ;
        p.substeps = n;
        p.timestep = control_dt / n;
        const double floor = contact_floor(p);
        std::vector<double> tcs{floor};
        for (double tc : {P.contact_solref[0], 2 * p.timestep})
          if (tc > floor * (1 + 1e-6)) tcs.push_back(tc);
        for (double tc : tcs) {
          p.contact_solref[0] = tc;
          p.coupling_solref[0] = tc;
          add("integrator", std::string(integ) + ", substeps=" + std::to_string(n) + ", solrefs " +
                                fmt("%.3g", tc * 1e3) + " ms", p, H);
        }
      }
    }
    // discrete without REFSAFE: contacts stiffer than the step (its docs: stable at any time
    // constant), at half and a quarter of the timestep
    for (int n : {6, 4}) {
      sim::PhysicsOptions p = P;
      p.integrator = "discrete";
      p.refsafe = false;
      p.substeps = n;
      p.timestep = control_dt / n;
      for (double f : {0.5, 0.25}) {
        p.contact_solref[0] = p.coupling_solref[0] = f * p.timestep;
        add("integrator", "discrete, substeps=" + std::to_string(n) + ", solrefs " +
                              fmt("%.3g", p.contact_solref[0] * 1e3) + " ms, no REFSAFE", p, H);
      }
    }
    for (const char* integ : {"Euler", "discrete"}) {
      for (int n : {4, 2}) {
        sim::PhysicsOptions p = P;
        p.integrator = integ;
        p.substeps = n;
        p.timestep = control_dt / n;
        const double tc = std::max(P.contact_solref[0],
                                   contact_floor(p));
        p.contact_solref[0] = p.coupling_solref[0] = tc;
        const std::string base = std::string(integ) + ", substeps=" + std::to_string(n) +
                                 ", solrefs " + fmt("%.3g", tc * 1e3) + " ms";
        sim::PhysicsOptions q = p;
        q.cone = "elliptic";
        add("integrator", base + ", elliptic", q, H);
        for (int it : {5, 10}) {
          q = p;
          q.iterations = it;
          add("integrator", base + ", Newton x" + std::to_string(it), q, H);
        }
      }
    }
  }
  if (want("solver")) {
    const std::pair<const char*, int> solvers[] = {{"Newton", 3},  {"Newton", 5},  {"Newton", 10},
                                                   {"Newton", 20}, {"CG", 20},     {"CG", 50},
                                                   {"PGS", 20},    {"PGS", 50},    {"PGS", 100}};
    for (auto [s, it] : solvers) {
      sim::PhysicsOptions p = P;
      p.solver = s;
      p.iterations = it;
      add("solver", std::string(s) + " x" + std::to_string(it), p, H);
    }
    for (double tol : {1e-6, 1e-8, 1e-10}) {
      sim::PhysicsOptions p = P;
      p.tolerance = tol;
      add("solver", "tolerance " + fmt("%g", tol), p, H);
    }
  }
  if (want("contact")) {
    // time constants below 2 dt are left out: REFSAFE would raise them to 2 dt
    for (double tc : {2 * P.timestep, 0.005, 0.01, 0.02, 0.04}) {
      if (tc < 2 * P.timestep * (1 - 1e-9)) continue;
      sim::PhysicsOptions p = P;
      p.contact_solref = {tc, P.contact_solref[1]};
      add("contact", "solref " + fmt("%.3g", tc), p, H);
    }
    for (double zeta : {0.5, 0.7, 1.0}) {
      sim::PhysicsOptions p = P;
      p.contact_solref = {P.contact_solref[0], zeta};
      add("contact", "dampratio " + fmt("%g", zeta), p, H);
    }
    const std::array<double, 5> imps[] = {{0.9, 0.95, 0.001, 0.5, 2},
                                          {0.95, 0.99, 0.001, 0.5, 2},
                                          {0.99, 0.999, 0.001, 0.5, 2},
                                          {0.95, 0.99, 0.005, 0.5, 2}};
    for (auto& imp : imps) {
      sim::PhysicsOptions p = P;
      p.contact_solimp = imp;
      add("contact", "solimp " + fmt("%g", imp[0]) + " " + fmt("%g", imp[1]) + " " +
                         fmt("%g", imp[2]), p, H);
    }
  }
  if (want("coupling")) {
    for (double tc : {2 * P.timestep, 0.005, 0.01, 0.02}) {
      if (tc < 2 * P.timestep * (1 - 1e-9)) continue;
      sim::PhysicsOptions p = P;
      p.coupling_solref = {tc, P.coupling_solref[1]};
      add("coupling", "solref " + fmt("%.3g", tc), p, H);
    }
    const std::array<double, 5> imps[] = {{0.9, 0.95, 0.001, 0.5, 2},
                                          {0.99, 0.999, 0.001, 0.5, 2},
                                          {0.999, 0.9999, 0.001, 0.5, 2}};
    for (auto& imp : imps) {
      sim::PhysicsOptions p = P;
      p.coupling_solimp = imp;
      add("coupling", "solimp " + fmt("%g", imp[0]) + " " + fmt("%g", imp[1]), p, H);
    }
  }
  if (want("damping")) {
    for (double c : {0.05, 0.1, 0.2, 0.5}) {
      HandTuning h = H;
      h.finger_damping = c;
      add("damping", "finger damping " + fmt("%g", c), P, h);
    }
  }
  if (want("frictionloss")) {
    for (double f : {0.0, 0.001}) {
      HandTuning h = H;
      h.frictionloss = f;
      add("frictionloss", "joint frictionloss " + fmt("%g", f), P, h);
    }
  }
  if (want("kp")) {
    for (double kp : {0.5, 1.0, 2.0, 5.0}) {
      HandTuning h = H;
      h.finger_kp = kp;
      add("kp", "finger kp " + fmt("%g", kp), P, h);
    }
  }
  if (want("base")) {
    for (double c : {250.0, 500.0, 1000.0}) {
      HandTuning h = H;
      h.base_translation = c;
      add("base", "base translation " + fmt("%g", c), P, h);
    }
    for (double c : {5.0, 10.0, 20.0}) {
      HandTuning h = H;
      h.base_rotation = c;
      add("base", "base rotation " + fmt("%g", c), P, h);
    }
  }
  return out;
}

sim::SceneBuilder rest_scene(const sim::HandSpec& right, const sim::PhysicsOptions& physics) {
  sim::SceneBuilder sb(physics);
  sb.add_hand(right, {sim::Side::kRight, sim::Pose::rpy({0, 0, 0.5}, 0, 0, 0), sim::Base::kFixed});
  sb.add_hand(right,
              {sim::Side::kLeft, sim::Pose::rpy({0, -1.15, 0.5}, 0, 0, M_PI), sim::Base::kFixed});
  sim::ObjectSpec egg;
  egg.name = "object";
  egg.shape = sim::ObjectSpec::Shape::kEllipsoid;
  egg.size = {0.03, 0.03, 0.04};
  egg.mass = 0.075;
  egg.damping = 0.01;
  egg.pose = sim::Pose::rpy({0, -0.39, 0.54}, M_PI / 2, 0, 0);  // lying along the fingers
  sb.add_object(egg);
  return sb;
}

namespace {

struct EggContacts {
  double max_penetration = 0;
  bool on_hand = false;
};

EggContacts egg_contacts(const mjModel* m, const mjData* d, int egg_geom,
                         const std::vector<char>& hand_body) {
  EggContacts e;
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& con = d->contact[c];
    int other = con.geom1 == egg_geom ? con.geom2 : con.geom2 == egg_geom ? con.geom1 : -1;
    if (other < 0) continue;
    e.max_penetration = std::max(e.max_penetration, -con.dist);
    if (hand_body[m->geom_bodyid[other]]) e.on_hand = true;
  }
  return e;
}

}  // namespace

json measure_rest(const sim::SimModel& model) {
  const mjModel* m = model.mj();
  const sim::ObjectIndex* egg = model.object("object");
  if (!egg || egg->qpos_adr < 0) throw ModelError("the scene has no free object named 'object'");
  const sim::HandIndex& right = hand_of(model, sim::Side::kRight);
  const int egg_geom = m->body_geomadr[egg->body];
  const int palm = mj_name2id(m, mjOBJ_BODY, (right.prefix + "palm").c_str());
  if (palm < 0) throw ModelError("the right hand has no palm body");
  std::vector<char> right_body(m->nbody, 0);
  for (int b : right.bodies) right_body[b] = 1;
  json out;

  // 1. settle 1 s, rest 2 s, then squeeze: the four fingers close on the egg for 1 s
  {
    World w(model);
    const int n_settle = w.steps_for(1.0), n_rest = w.steps_for(2.0), n_squeeze = w.steps_for(1.0);
    double pen_settle = 0, pen_rest = 0, pen_rest_sum = 0, pen_squeeze = 0;
    for (int i = 0; i < n_settle; ++i) {
      w.step();
      pen_settle = std::max(pen_settle, egg_contacts(m, w.d, egg_geom, right_body).max_penetration);
    }
    const double* pe = w.d->xpos + 3 * egg->body;
    auto p1 = vec3(pe);
    auto r1 = in_body_frame(w.d, palm, pe);
    for (int i = 0; i < n_rest; ++i) {
      w.step();
      double pen = egg_contacts(m, w.d, egg_geom, right_body).max_penetration;
      pen_rest = std::max(pen_rest, pen);
      pen_rest_sum += pen;
    }
    auto p2 = vec3(pe);
    auto r2 = in_body_frame(w.d, palm, pe);
    const bool rest_on_hand = egg_contacts(m, w.d, egg_geom, right_body).on_hand;
    const double rest_speed = norm3(w.d->qvel + egg->dof_adr);
    for (const char* f : {"FF", "MF", "RF", "LF"})
      for (const char* j : {"3", "2"}) {
        int a = actuator_of(right, std::string(f) + j);
        w.d->ctrl[a] = w.m->actuator_ctrlrange[2 * a + 1];
      }
    for (int i = 0; i < n_squeeze; ++i) {
      w.step();
      if (i >= n_squeeze / 2)
        pen_squeeze = std::max(pen_squeeze,
                               egg_contacts(m, w.d, egg_geom, right_body).max_penetration);
    }
    out["max_penetration_settle_m"] = pen_settle;
    out["max_penetration_rest_m"] = pen_rest;
    out["mean_penetration_rest_m"] = pen_rest_sum / std::max(1, n_rest);
    out["drift_world_2s_m"] = dist3(p1, p2);
    out["drift_palm_2s_m"] = dist3(r1, r2);
    out["egg_speed_end_m_s"] = rest_speed;
    out["egg_on_hand"] = rest_on_hand;
    out["max_penetration_squeeze_m"] = pen_squeeze;
    out["egg_on_hand_squeeze"] = egg_contacts(m, w.d, egg_geom, right_body).on_hand;

    // a grasp held against gravity: still squeezed, the world is turned over (gravity along the
    // palm's normal, away from it: the closed hand palm down) for 10 s; the fingers alone hold
    // the egg. Its slip in the palm's frame and whether it stays in the hand.
    {
      mjModel* over = mj_copyModel(nullptr, m);
      for (int k = 0; k < 3; ++k) over->opt.gravity[k] = -m->opt.gravity[k];
      const auto h0 = in_body_frame(w.d, palm, pe);
      const int n_hold = w.steps_for(10.0);
      double slip = 0, pen_hold = 0, left_at = -1;
      for (int i = 0; i < n_hold; ++i) {
        w.step(over);
        EggContacts e = egg_contacts(m, w.d, egg_geom, right_body);
        pen_hold = std::max(pen_hold, e.max_penetration);
        slip = std::max(slip, dist3(h0, in_body_frame(w.d, palm, pe)));
        if (left_at < 0 && !e.on_hand) left_at = (i + 1) * w.dt();
      }
      out["hold"] = {{"seconds", 10.0},
                     {"max_slip_palm_m", slip},
                     {"slip_palm_end_m", dist3(h0, in_body_frame(w.d, palm, pe))},
                     {"max_penetration_m", pen_hold},
                     {"first_left_hand_s", left_at},
                     {"egg_on_hand_end", egg_contacts(m, w.d, egg_geom, right_body).on_hand},
                     {"finite", w.finite()}};
      mj_deleteModel(over);
    }
    out["warnings"] = sim::warning_total(w.d);
    out["finite"] = w.finite();
  }

  // 2. a catch in miniature: the egg dropped from 20 cm above its start onto the palm
  {
    World w(model);
    w.d->qpos[egg->qpos_adr + 2] += 0.2;
    mj_forward(w.m, w.d);
    const int n = w.steps_for(1.5);
    double pen = 0, impact_speed = 0, first_contact_z = -1, bounce = 0;
    for (int i = 0; i < n; ++i) {
      double vz = w.d->qvel[egg->dof_adr + 2];
      w.step();
      EggContacts e = egg_contacts(m, w.d, egg_geom, right_body);
      pen = std::max(pen, e.max_penetration);
      const double z = w.d->xpos[3 * egg->body + 2];
      if (first_contact_z < 0 && e.on_hand) {
        first_contact_z = z;
        impact_speed = std::abs(vz);
      }
      if (first_contact_z >= 0) bounce = std::max(bounce, z - first_contact_z);
    }
    out["drop"] = {{"height_m", 0.2},
                   {"impact_speed_m_s", impact_speed},
                   {"max_penetration_m", pen},
                   {"max_rebound_m", bounce},
                   {"egg_on_hand_after_1_5s", egg_contacts(m, w.d, egg_geom, right_body).on_hand},
                   {"warnings", sim::warning_total(w.d)},
                   {"finite", w.finite()}};
  }
  return out;
}

json measure_coupling(const sim::SimModel& model, const sim::HandSpec& spec) {
  World w(model);
  auto cps = coupling_index(model, spec);
  const auto& hands = model.hands();
  std::vector<int> acts;
  for (auto& h : hands)
    for (auto& c : spec.couplings) acts.push_back(actuator_of(h, c.follows));
  std::vector<double> err(hands.size(), 0.0);
  const int ramp = static_cast<int>(std::lround(1.0 / w.model.physics().control_dt()));
  const int total = ramp + ramp / 2;
  for (int k = 0; k < total; ++k) {
    double frac = std::min(1.0, (k + 1.0) / ramp);
    for (int a : acts) {
      double lo = w.m->actuator_ctrlrange[2 * a], hi = w.m->actuator_ctrlrange[2 * a + 1];
      w.d->ctrl[a] = std::clamp(frac * M_PI / 2, lo, hi);
    }
    for (int s = 0; s < w.substeps(); ++s) {
      w.step();
      for (auto& c : cps)
        err[c.hand] = std::max(err[c.hand], std::abs(w.d->qpos[c.qa] - c.ratio * w.d->qpos[c.qb]));
    }
  }
  // the smallest middle angle at the end, per hand: how far the sweep really went (the right
  // hand's fingers may close on the egg)
  std::vector<double> reached(hands.size(), 1e9);
  for (auto& c : cps) reached[c.hand] = std::min(reached[c.hand], w.d->qpos[c.qb]);
  json per_hand = json::object(), angle = json::object();
  double worst = 0;
  for (size_t h = 0; h < hands.size(); ++h) {
    per_hand[sim::side_name(hands[h].side)] = err[h];
    angle[sim::side_name(hands[h].side)] = reached[h];
    worst = std::max(worst, err[h]);
  }
  return {{"max_error_rad", worst},
          {"max_error_rad_by_hand", per_hand},
          {"min_middle_angle_end_rad_by_hand", angle},
          {"warnings", sim::warning_total(w.d)},
          {"finite", w.finite()}};
}

PhysxDampedResponse physx_damped_response(const sim::SimModel& model, const sim::HandIndex& hand,
                                          double damping, double substep) {
  const mjModel* m = model.mj();
  mjData* d = mj_makeData(m);
  mj_forward(m, d);
  PhysxDampedResponse r;
  double com[3] = {0, 0, 0};
  for (int b : hand.bodies) {
    r.mass += m->body_mass[b];
    for (int k = 0; k < 3; ++k) com[k] += m->body_mass[b] * d->xipos[3 * b + k];
  }
  for (double& c : com) c /= r.mass;
  // inertia about the centre of mass, world axes: each body's own (R diag R^T) plus m (|r|^2 1 - r r^T)
  double inertia[9] = {};
  for (int b : hand.bodies) {
    const double* rot = d->ximat + 9 * b;
    const double* diag = m->body_inertia + 3 * b;
    const double rel[3] = {d->xipos[3 * b] - com[0], d->xipos[3 * b + 1] - com[1],
                           d->xipos[3 * b + 2] - com[2]};
    const double r2 = rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double own = 0;
        for (int k = 0; k < 3; ++k) own += rot[3 * i + k] * diag[k] * rot[3 * j + k];
        inertia[3 * i + j] += own + m->body_mass[b] * ((i == j ? r2 : 0.0) - rel[i] * rel[j]);
      }
  }
  mj_deleteData(d);
  for (int k = 0; k < 3; ++k) r.inertia[k] = inertia[4 * k];
  // v* = (v* + a h) k  =>  v* = a h k / (1 - k): a damping of m (1 - k) / (h k) in N s/m
  const double keep = std::max(0.0, 1.0 - damping * substep);
  const double per_unit = (1.0 - keep) / (substep * keep);
  r.linear_damping = r.mass * per_unit;
  for (int k = 0; k < 3; ++k) r.angular_damping[k] = r.inertia[k] * per_unit;
  return r;
}

json measure_hang(const sim::SimModel& model, double force, double torque) {
  const int left = hand_number(model, sim::Side::kLeft);
  const int right = hand_number(model, sim::Side::kRight);
  const auto& hands = model.hands();
  if (!hands[left].free_base || !hands[right].free_base)
    throw ModelError("the hang measurement needs free bases");
  const mjModel* m = model.mj();
  const double c_lin = m->dof_damping[hands[left].base_dof_adr];
  const double c_rot = m->dof_damping[hands[left].base_dof_adr + 3];

  struct Run {
    double drift_pos, drift_angle;      // of the left base
    double drift_pos_right, drift_angle_right;
    double speed, spin;                 // left base, mean over the last 0.5 s
    int warnings;
  };
  auto run = [&](const std::array<double, 6>& left_wrench) {
    World w(model);
    for (int k = 0; k < 6; ++k) w.wrench[left * 6 + k] = left_wrench[k];
    const int n = w.steps_for(2.0), tail = w.steps_for(0.5);
    const int ql = hands[left].base_qpos_adr, qr = hands[right].base_qpos_adr;
    const int vl = hands[left].base_dof_adr;
    std::array<double, 3> l0 = vec3(w.d->qpos + ql), r0 = vec3(w.d->qpos + qr);
    double speed = 0, spin = 0;
    for (int i = 0; i < n; ++i) {
      w.step();
      if (i >= n - tail) {
        speed += norm3(w.d->qvel + vl) / tail;
        spin += norm3(w.d->qvel + vl + 3) / tail;
      }
    }
    return Run{dist3(l0, vec3(w.d->qpos + ql)), quat_angle(w.d->qpos + ql + 3),
               dist3(r0, vec3(w.d->qpos + qr)), quat_angle(w.d->qpos + qr + 3), speed, spin,
               sim::warning_total(w.d)};
  };
  Run still = run({0, 0, 0, 0, 0, 0});
  Run push = run({force, 0, 0, 0, 0, 0});
  Run twist = run({0, 0, 0, 0, 0, torque});
  // the hands lie along the world y axis: a torque about y rolls the hand about its forearm
  Run roll = run({0, 0, 0, 0, torque, 0});
  const PhysxDampedResponse orig = physx_damped_response(model, hands[left]);
  return {{"still_left_drift_2s_m", still.drift_pos},
          {"still_left_rotation_2s_rad", still.drift_angle},
          {"still_right_drift_2s_m", still.drift_pos_right},
          {"still_right_rotation_2s_rad", still.drift_angle_right},
          {"push_force_n", force},
          {"push_speed_m_s", push.speed},
          {"push_expected_speed_m_s", force / c_lin},
          {"push_induced_spin_rad_s", push.spin},
          {"twist_torque_nm", torque},
          {"twist_spin_rad_s", twist.spin},
          {"twist_expected_spin_rad_s", torque / c_rot},
          {"roll_spin_rad_s", roll.spin},
          {"original",
           {{"what", "the original's steady response under the same force and torque: PhysX "
                     "damping 100 on every hand link, v <- (v + a dt) max(0, 1 - c dt) per "
                     "1/120 s substep, on this hand's mass and inertia about its centre of mass"},
            {"mass_kg", orig.mass},
            {"inertia_com_kgm2", orig.inertia},
            {"push_speed_m_s", force / orig.linear_damping},
            {"twist_spin_rad_s", torque / orig.angular_damping[2]},
            {"roll_spin_rad_s", torque / orig.angular_damping[1]},
            {"equivalent_damping_translation", orig.linear_damping},
            {"equivalent_damping_rotation", orig.angular_damping}}},
          {"warnings", still.warnings + push.warnings + twist.warnings + roll.warnings}};
}

json measure_step(const sim::SimModel& model, double step_rad) {
  const sim::HandIndex& left = hand_of(model, sim::Side::kLeft);
  json out = json::object();
  for (const char* joint : {"FF3", "FF2"}) {
    World w(model);
    const int a = actuator_of(left, joint), q = joint_qadr(left, joint);
    const double q0 = w.d->qpos[q];
    const double target = std::clamp(q0 + step_rad, w.m->actuator_ctrlrange[2 * a],
                                      w.m->actuator_ctrlrange[2 * a + 1]);
    const double size = target - q0;
    w.d->ctrl[a] = target;
    const int n = w.steps_for(1.0);
    double t10 = -1, t90 = -1, peak = q0, settle = 0, prev = q0;
    for (int i = 0; i < n; ++i) {
      w.step();
      const double t = (i + 1) * w.dt(), x = w.d->qpos[q];
      auto cross = [&](double level, double& at) {
        if (at < 0 && (x - q0) / size >= level) {
          double f = (level * size - (prev - q0)) / (x - prev);
          at = t - w.dt() + f * w.dt();
        }
      };
      cross(0.1, t10);
      cross(0.9, t90);
      peak = std::max(peak, x);
      if (std::abs(x - target) > 0.02 * std::abs(size)) settle = t;
      prev = x;
    }
    out[joint] = {{"step_rad", size},
                  {"rise_time_10_90_s", t10 >= 0 && t90 >= 0 ? t90 - t10 : -1.0},
                  {"time_to_90_s", t90},
                  {"overshoot", std::max(0.0, (peak - target) / size)},
                  {"settling_time_2pct_s", settle},
                  {"error_after_1s_rad", std::abs(w.d->qpos[q] - target)},
                  {"warnings", sim::warning_total(w.d)}};
  }
  return out;
}

namespace {

// which kind of pair a contact is, for penetration figures per kind
enum ContactKind { kObjectHand, kObjectWorld, kHandHand, kHandSelf, kHandWorld, kOther, kKinds };
const char* const kKindNames[kKinds] = {"object_hand", "object_world", "hand_hand",
                                        "hand_self",   "hand_world",   "other"};

struct ContactClassifier {
  std::vector<int> hand_of_body;  // -1: no hand
  std::vector<char> object_body;

  explicit ContactClassifier(const sim::SimModel& model) {
    const mjModel* m = model.mj();
    hand_of_body.assign(m->nbody, -1);
    object_body.assign(m->nbody, 0);
    for (size_t h = 0; h < model.hands().size(); ++h)
      for (int b : model.hands()[h].bodies) hand_of_body[b] = static_cast<int>(h);
    for (auto& o : model.objects()) object_body[o.body] = 1;
  }
  ContactKind kind(const mjModel* m, const mjContact& c) const {
    int b1 = m->geom_bodyid[c.geom1], b2 = m->geom_bodyid[c.geom2];
    int h1 = hand_of_body[b1], h2 = hand_of_body[b2];
    bool o1 = object_body[b1], o2 = object_body[b2];
    if (o1 || o2) {
      if (h1 >= 0 || h2 >= 0) return kObjectHand;
      return o1 && o2 ? kOther : kObjectWorld;
    }
    if (h1 >= 0 && h2 >= 0) return h1 == h2 ? kHandSelf : kHandHand;
    if (h1 >= 0 || h2 >= 0) return kHandWorld;
    return kOther;
  }
};

}  // namespace

namespace {

double thread_cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

struct Timing {
  double wall = 1e300, cpu = 1e300;  // best round
};

// one round: a fresh batch (the same seed, so the same work every round)
void cost_round(const sim::SimModel& model, const CostRun& run, Timing& best) {
  sim::SimBatch batch(model, run.slots, {1, run.seed});
  double wall = 0, cpu = 0;
  for (int i = 0; i < run.steps; ++i) {
    sim::random_inputs(model, batch, run.max_force, run.max_torque);
    auto t0 = Clock::now();
    double c0 = thread_cpu_seconds();
    sim::step(model, batch);  // one thread: the parallel loop runs on this thread
    cpu += thread_cpu_seconds() - c0;
    wall += seconds_since(t0);
  }
  best.wall = std::min(best.wall, wall);
  best.cpu = std::min(best.cpu, cpu);
}

}  // namespace

json measure_cost(const sim::SimModel& model, const CostRun& run,
                  const sim::SimModel* reference) {
  Timing mine, ref;
  for (int r = 0; r < run.rounds; ++r) {
    if (reference) cost_round(*reference, run, ref);
    cost_round(model, run, mine);
  }
  const double n = static_cast<double>(run.slots) * run.steps;
  const int substeps = model.physics().substeps;
  json out = {{"slots", run.slots},
              {"control_steps", run.steps},
              {"rounds", run.rounds},
              {"threads", 1},
              {"best_cpu_seconds", mine.cpu},
              {"best_wall_seconds", mine.wall},
              {"slot_steps_per_s", n / mine.cpu},
              {"physics_steps_per_s", n * substeps / mine.cpu},
              {"wall_slot_steps_per_s", n / mine.wall}};
  if (reference) {
    out["reference_slot_steps_per_s"] = n / ref.cpu;
    out["relative_to_reference"] = ref.cpu / mine.cpu;  // > 1: faster than the reference
  }
  return out;
}

json measure_soak(const sim::SimModel& model, const sim::HandSpec& spec, const StudySoak& soak,
                  const std::function<void(int64_t)>& tick) {
  sim::SimBatch batch(model, soak.slots, {1, soak.seed});
  const mjModel* m = model.mj();
  const int64_t steps = (soak.slot_steps + soak.slots - 1) / soak.slots;
  const auto cps = coupling_index(model, spec);
  const ContactClassifier classify(model);
  SoakTally tally;
  int max_iter = 0;
  int64_t iter_sum = 0, iter_capped = 0, iter_n = 0;
  double max_pen[kKinds] = {}, max_coupling = 0, max_qvel = 0, secs = 0;
  std::vector<float> pens[kKinds], coups;
  coups.reserve(steps * soak.slots);
  const int nv = model.nv();
  for (int64_t i = 0; i < steps; ++i) {
    sim::random_inputs(model, batch, soak.max_force, soak.max_torque);
    auto t0 = Clock::now();
    sim::step(model, batch);
    secs += seconds_since(t0);
    tally.add(batch);
    for (int s = 0; s < batch.nslot(); ++s) {
      const mjData* d = batch.data(s);
      if (batch.fault[s]) continue;
      // solver iterations of the last physics step of the control step (the most of any
      // constraint island; MuJoCo solves islands apart)
      int iter = d->solver_niter[0];
      for (int i = 1; i < std::min(d->nisland, mjNISLAND); ++i)
        iter = std::max(iter, d->solver_niter[i]);
      max_iter = std::max(max_iter, iter);
      iter_sum += iter;
      iter_capped += iter >= m->opt.iterations;
      ++iter_n;
      double pen[kKinds] = {};
      bool seen[kKinds] = {};
      for (int c = 0; c < d->ncon; ++c) {
        ContactKind k = classify.kind(m, d->contact[c]);
        pen[k] = std::max(pen[k], -d->contact[c].dist);
        seen[k] = true;
      }
      for (int k = 0; k < kKinds; ++k) {
        if (!seen[k]) continue;
        max_pen[k] = std::max(max_pen[k], pen[k]);
        pens[k].push_back(static_cast<float>(pen[k]));
      }
      const double* qpos = batch.qpos.data() + static_cast<size_t>(s) * batch.qpos_width;
      double ce = 0;
      for (auto& c : cps) ce = std::max(ce, std::abs(qpos[c.qa] - c.ratio * qpos[c.qb]));
      max_coupling = std::max(max_coupling, ce);
      coups.push_back(static_cast<float>(ce));
      const double* qvel = batch.qvel.data() + static_cast<size_t>(s) * batch.qvel_width;
      for (int k = 0; k < nv; ++k) max_qvel = std::max(max_qvel, std::abs(qvel[k]));
    }
    reset_finished_episodes(model, batch, i, soak.episode_steps);
    if (tick) tick((i + 1) * soak.slots);
  }
  const int64_t slot_steps = steps * soak.slots;
  const double sps = slot_steps / secs;
  json pen = json::object();
  double pen_all = 0;
  for (int k = 0; k < kKinds; ++k) {
    pen_all = std::max(pen_all, max_pen[k]);
    if (pens[k].empty()) continue;
    pen[kKindNames[k]] = {{"slot_steps_with_contact", pens[k].size()},
                          {"max_m", max_pen[k]},
                          {"p99_m", percentile(pens[k], 0.99)},
                          {"p50_m", percentile(pens[k], 0.5)}};
  }
  json out{{"slots", soak.slots},
          {"slot_steps", slot_steps},
          {"max_force_n", soak.max_force},
          {"max_torque_nm", soak.max_torque},
          {"episode_steps", soak.episode_steps},
          {"seed", soak.seed},
          {"threads", 1},
          {"step_seconds", secs},
          {"slot_steps_per_s", sps},
          {"physics_steps_per_s", sps * model.physics().substeps},
          {"faults", batch.total_faults()},
          {"solver_iterations_mean", iter_n ? static_cast<double>(iter_sum) / iter_n : 0.0},
          {"solver_iterations_max", max_iter},
          {"solver_at_iteration_cap", iter_capped},
          {"max_penetration_m", pen_all},
          {"penetration_by_contact_kind", pen},
          {"max_coupling_error_rad", max_coupling},
          {"p99_coupling_error_rad", percentile(coups, 0.99)},
          {"max_abs_qvel", max_qvel}};
  tally.to_json(out);
  return out;
}

json run_physics_study(const PhysicsStudyConfig& cfg) {
  const std::string hand_path = cfg.hand_path.empty() ? sim::default_hand_path() : cfg.hand_path;
  const sim::HandSpec spec0 = sim::load_hand_spec(hand_path);
  const HandTuning h0 = hand_tuning(spec0);
  const auto cands = study_candidates(cfg.physics, h0, cfg.groups);

  auto rounded = [](const StudySoak& s) {
    return s.slot_steps > 0 ? (s.slot_steps + s.slots - 1) / s.slots * s.slots : 0;
  };
  const int64_t per = rounded(cfg.soak) + rounded(cfg.hard);  // the cost runs are not counted
  int64_t full = 0;
  for (auto& c : cands) full += c.cost_only ? 0 : 1;
  Progress bar("bench physics", per * full, "slot-steps");
  int64_t done = 0;

  json out;
  out["reference"] = {{"physics", physics_json(cfg.physics)},
                      {"hand", hand_json(h0)},
                      {"hand_file", hand_path}};
  out["settings"] = {{"soak", {{"slots", cfg.soak.slots},
                               {"slot_steps", cfg.soak.slot_steps},
                               {"max_force_n", cfg.soak.max_force},
                               {"max_torque_nm", cfg.soak.max_torque},
                               {"episode_steps", cfg.soak.episode_steps}}},
                     {"hard", {{"slots", cfg.hard.slots},
                               {"slot_steps", cfg.hard.slot_steps},
                               {"max_force_n", cfg.hard.max_force},
                               {"max_torque_nm", cfg.hard.max_torque},
                               {"episode_steps", cfg.hard.episode_steps}}},
                     {"cost", {{"slots", cfg.cost.slots},
                               {"control_steps", cfg.cost.steps},
                               {"rounds", cfg.cost.rounds},
                               {"max_force_n", cfg.cost.max_force},
                               {"max_torque_nm", cfg.cost.max_torque}}},
                     {"groups", cfg.groups}};
  out["candidates"] = json::array();
  json summary = json::array();
  int64_t max_arena = 0, ref_arena = 0;         // over every candidate, the reference's soaks
  int max_con = 0, max_efc = 0;                 // over every candidate
  int ref_con = 0, ref_efc = 0;                 // over the reference's soaks
  json arena_by_solver = json::object();
  std::optional<sim::SimModel> reference;  // timed beside every other candidate
  for (const Candidate& c : cands) {
    auto t0 = Clock::now();
    sim::HandSpec spec = apply_tuning(spec0, c.hand);
    sim::SimModel model = sim::two_hand_scene(spec, c.physics).build("two_hand_scene");
    json e;
    e["group"] = c.group;
    e["name"] = c.name;
    e["physics"] = physics_json(c.physics);
    e["hand"] = hand_json(c.hand);
    e["effective_timeconst"] = {{"contact", effective_contact_timeconst(c.physics)},
                                {"coupling", effective_coupling_timeconst(c.physics)}};
    e["mjdata_bytes_per_slot"] = model.data_bytes();
    if (c.cost_only) {
      if (cfg.cost.rounds <= 0) continue;
      e["cost"] = measure_cost(model, cfg.cost, reference ? &*reference : nullptr);
      summary.push_back({{"group", c.group},
                         {"name", c.name},
                         {"slot_steps_per_s", e["cost"]["slot_steps_per_s"]},
                         {"physics_steps_per_s", e["cost"]["physics_steps_per_s"]},
                         {"speed_vs_reference", e["cost"]["relative_to_reference"]}});
      e["seconds"] = seconds_since(t0);
      out["candidates"].push_back(std::move(e));
      continue;
    }
    e["rest"] = measure_rest(rest_scene(spec, c.physics).build("rest_scene"));
    e["coupling"] = measure_coupling(model, spec);
    e["hang"] = measure_hang(model, cfg.soak.max_force, cfg.soak.max_torque);
    e["step"] = measure_step(model);
    if (cfg.cost.rounds > 0)
      e["cost"] = measure_cost(model, cfg.cost, reference ? &*reference : nullptr);
    auto tick = [&](int64_t n) {
      if (cfg.progress) bar.update(done + n);
    };
    if (cfg.soak.slot_steps > 0) {
      e["soak"] = measure_soak(model, spec, cfg.soak, tick);
      done += rounded(cfg.soak);
    }
    if (cfg.hard.slot_steps > 0) {
      e["hard"] = measure_soak(model, spec, cfg.hard, tick);
      done += rounded(cfg.hard);
    }
    e["seconds"] = seconds_since(t0);
    if (!reference) reference.emplace(std::move(model));  // the first candidate
    for (const char* s : {"soak", "hard"}) {
      if (!e.contains(s)) continue;
      if (c.group == "reference") {
        ref_arena = std::max(ref_arena, e[s]["maxuse_arena"].get<int64_t>());
        ref_con = std::max(ref_con, e[s]["maxuse_con"].get<int>());
        ref_efc = std::max(ref_efc, e[s]["maxuse_efc"].get<int>());
      }
      max_arena = std::max(max_arena, e[s]["maxuse_arena"].get<int64_t>());
      max_con = std::max(max_con, e[s]["maxuse_con"].get<int>());
      max_efc = std::max(max_efc, e[s]["maxuse_efc"].get<int>());
      int64_t prev = arena_by_solver.value(c.physics.solver, int64_t{0});
      arena_by_solver[c.physics.solver] = std::max(prev, e[s]["maxuse_arena"].get<int64_t>());
    }
    // one line per candidate with the figures the README compares
    json row = {{"group", c.group}, {"name", c.name}};
    if (e.contains("cost")) {
      row["slot_steps_per_s"] = e["cost"]["slot_steps_per_s"];
      row["physics_steps_per_s"] = e["cost"]["physics_steps_per_s"];
      if (e["cost"].contains("relative_to_reference"))
        row["speed_vs_reference"] = e["cost"]["relative_to_reference"];
    }
    if (e.contains("soak")) {
      row["faults"] = e["soak"]["faults"];
      row["soak_max_coupling_error_rad"] = e["soak"]["max_coupling_error_rad"];
      row["soak_solver_iterations_max"] = e["soak"]["solver_iterations_max"];
      row["soak_maxuse_efc"] = e["soak"]["maxuse_efc"];
      const json& oh = e["soak"]["penetration_by_contact_kind"];
      if (oh.contains("object_hand"))
        row["soak_p99_penetration_object_hand_m"] = oh["object_hand"]["p99_m"];
    }
    if (e.contains("hard")) {
      row["hard_faults"] = e["hard"]["faults"];
      row["hard_max_penetration_m"] = e["hard"]["max_penetration_m"];
      row["hard_maxuse_efc"] = e["hard"]["maxuse_efc"];
    }
    row["rest_penetration_m"] = e["rest"]["max_penetration_rest_m"];
    row["squeeze_penetration_m"] = e["rest"]["max_penetration_squeeze_m"];
    row["drop_penetration_m"] = e["rest"]["drop"]["max_penetration_m"];
    row["rest_drift_palm_m"] = e["rest"]["drift_palm_2s_m"];
    row["hold_slip_palm_m"] = e["rest"]["hold"]["slip_palm_end_m"];
    row["hold_egg_on_hand"] = e["rest"]["hold"]["egg_on_hand_end"];
    row["egg_on_hand"] = e["rest"]["egg_on_hand"];
    row["coupling_error_rad"] = e["coupling"]["max_error_rad"];
    row["hang_drift_m"] = e["hang"]["still_left_drift_2s_m"];
    row["push_speed_m_s"] = e["hang"]["push_speed_m_s"];
    row["ff3_rise_s"] = e["step"]["FF3"]["rise_time_10_90_s"];
    row["ff3_overshoot"] = e["step"]["FF3"]["overshoot"];
    summary.push_back(row);
    out["candidates"].push_back(std::move(e));
  }
  if (cfg.progress) bar.finish();
  out["summary"] = summary;

  // memory: bytes of one mjData for several buffer sizes, against the largest use seen
  json mem;
  mem["reference_max"] = {{"maxuse_arena", ref_arena},
                          {"maxuse_con", ref_con},
                          {"maxuse_efc", ref_efc}};
  mem["observed_max"] = {{"maxuse_arena", max_arena},
                         {"maxuse_con", max_con},
                         {"maxuse_efc", max_efc},
                         {"maxuse_arena_by_solver", arena_by_solver}};
  mem["slots"] = cfg.memory_slots;
  mem["sizes"] = json::array();
  const int sizes[] = {cfg.physics.memory, 4 << 20, 2 << 20, 1 << 20, 768 << 10, 512 << 10,
                       384 << 10, 256 << 10};
  std::vector<int> seen;
  for (int sz : sizes) {
    if (std::find(seen.begin(), seen.end(), sz) != seen.end()) continue;
    seen.push_back(sz);
    sim::PhysicsOptions p = cfg.physics;
    p.memory = sz;
    json row = {{"memory", sz},
                {"reference", seen.size() == 1},
                // over the largest use of the reference's soaks
                {"headroom", static_cast<double>(sz) / std::max<int64_t>(1, ref_arena)}};
    try {
      sim::SimModel model = sim::two_hand_scene(spec0, p).build("two_hand_scene");
      row["mjdata_bytes_per_slot"] = model.data_bytes();
      row["gb_for_slots"] = static_cast<double>(model.data_bytes()) * cfg.memory_slots / 1e9;
    } catch (const ModelError& e) {
      // MuJoCo's compiler runs a forward pass: too small an arena fails already there
      row["error"] = e.what();
    }
    mem["sizes"].push_back(row);
  }
  out["memory"] = mem;
  return out;
}

}  // namespace bidex::bench
