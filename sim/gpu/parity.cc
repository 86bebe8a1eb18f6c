#include "sim/gpu/parity.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <sstream>

#include <mujoco/mujoco.h>

namespace bidex::sim::gpu {

namespace {

double seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

// Values of one field gathered over all worlds, judged once all are in (the of_max part of the
// bound needs the field's largest value).
struct Pending {
  FieldCheck check;
  std::vector<double> eng, ref;
  std::vector<std::pair<int, int>> at;  // (world, index)
};

class Collector {
 public:
  explicit Collector(bool float32) : float32_(float32) {}

  void add(const std::string& stage, const std::string& field, const double* eng,
           const double* ref, int n, int world, int first = 0) {
    Pending& p = get(stage, field, false);
    for (int i = first; i < n; ++i) {
      p.eng.push_back(eng[i]);
      p.ref.push_back(ref[i]);
      p.at.push_back({world, i});
    }
  }
  void add_value(const std::string& stage, const std::string& field, double eng, double ref,
                 int world, int index) {
    Pending& p = get(stage, field, false);
    p.eng.push_back(eng);
    p.ref.push_back(ref);
    p.at.push_back({world, index});
  }
  void exact(const std::string& stage, const std::string& field, long eng, long ref, int world,
             int index) {
    Pending& p = get(stage, field, true);
    p.eng.push_back(static_cast<double>(eng));
    p.ref.push_back(static_cast<double>(ref));
    p.at.push_back({world, index});
  }

  std::vector<FieldCheck> finish() {
    std::vector<FieldCheck> out;
    for (const std::string& key : order_) {
      Pending& p = pending_[key];
      FieldCheck c = p.check;
      c.count = static_cast<long>(p.ref.size());
      double fmax = 0;
      for (double r : p.ref) fmax = std::max(fmax, std::abs(r));
      for (size_t i = 0; i < p.ref.size(); ++i) {
        const double err = std::abs(p.eng[i] - p.ref[i]);
        const bool nan = std::isnan(p.eng[i]) != std::isnan(p.ref[i]);
        double ratio;
        if (c.exact) {
          ratio = (err == 0 && !nan) ? 0.0 : INFINITY;
        } else {
          const double bound = c.tol.atol + c.tol.rtol * std::abs(p.ref[i]) + c.tol.of_max * fmax;
          ratio = nan ? INFINITY : (bound > 0 ? err / bound : (err > 0 ? INFINITY : 0.0));
        }
        if (!(ratio <= 1)) c.mismatched++;
        c.max_abs = nan ? INFINITY : std::max(c.max_abs, err);
        if (ratio > c.max_ratio) {
          c.max_ratio = ratio;
          c.worst = "world " + std::to_string(p.at[i].first) + " index " +
                    std::to_string(p.at[i].second) + ": engine " + std::to_string(p.eng[i]) +
                    ", mujoco " + std::to_string(p.ref[i]);
        }
      }
      out.push_back(c);
    }
    return out;
  }

 private:
  Pending& get(const std::string& stage, const std::string& field, bool exact) {
    const std::string key = stage + "/" + field;
    auto it = pending_.find(key);
    if (it != pending_.end()) return it->second;
    order_.push_back(key);
    Pending& p = pending_[key];
    p.check.stage = stage;
    p.check.field = field;
    p.check.exact = exact;
    if (!exact) p.check.tol = stage_tolerance(stage, float32_);
    return p;
  }
  bool float32_;
  std::map<std::string, Pending> pending_;
  std::vector<std::string> order_;
};

double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * (static_cast<double>(rng() >> 11) * 0x1.0p-53);
}
double normal(std::mt19937_64& rng, double sd) {
  std::normal_distribution<double> n(0.0, sd);
  return n(rng);
}

void random_quat(std::mt19937_64& rng, double* q) {
  double n = 0;
  for (int k = 0; k < 4; ++k) {
    q[k] = normal(rng, 1.0);
    n += q[k] * q[k];
  }
  // slightly off unit length: the engine must normalise as MuJoCo does
  const double s = uniform(rng, 0.98, 1.02) / std::sqrt(n);
  for (int k = 0; k < 4; ++k) q[k] *= s;
}

// A random state: joints inside their ranges widened by 10 % on each side (so some limits are
// violated), random velocities, controls beyond their ranges (clamping), applied forces and a
// random warm start.
void random_state(const mjModel* m, std::mt19937_64& rng, mjData* d) {
  mj_resetData(m, d);
  for (int j = 0; j < m->njnt; ++j) {
    double* q = d->qpos + m->jnt_qposadr[j];
    double* v = d->qvel + m->jnt_dofadr[j];
    const double* q0 = m->qpos0 + m->jnt_qposadr[j];
    switch (m->jnt_type[j]) {
      case mjJNT_FREE:
        for (int k = 0; k < 3; ++k) q[k] = q0[k] + uniform(rng, -0.3, 0.3);
        random_quat(rng, q + 3);
        for (int k = 0; k < 3; ++k) v[k] = normal(rng, 0.5);
        for (int k = 3; k < 6; ++k) v[k] = normal(rng, 2.0);
        break;
      case mjJNT_BALL:
        random_quat(rng, q);
        for (int k = 0; k < 3; ++k) v[k] = normal(rng, 1.0);
        break;
      default: {
        const bool slide = m->jnt_type[j] == mjJNT_SLIDE;
        if (m->jnt_limited[j]) {
          const double lo = m->jnt_range[2 * j], hi = m->jnt_range[2 * j + 1], w = hi - lo;
          q[0] = uniform(rng, lo - 0.1 * w, hi + 0.1 * w);
        } else {
          q[0] = q0[0] + uniform(rng, slide ? -0.3 : -3.0, slide ? 0.3 : 3.0);
        }
        v[0] = normal(rng, slide ? 0.3 : 2.0);
      }
    }
  }
  for (int a = 0; a < m->nu; ++a) {
    if (m->actuator_ctrllimited[a]) {
      const double lo = m->actuator_ctrlrange[2 * a], hi = m->actuator_ctrlrange[2 * a + 1];
      d->ctrl[a] = uniform(rng, lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo));
    } else {
      d->ctrl[a] = normal(rng, 1.0);
    }
  }
  for (int b = 1; b < m->nbody; ++b) {
    for (int k = 0; k < 3; ++k) d->xfrc_applied[6 * b + k] = normal(rng, 5.0 * m->body_mass[b]);
    for (int k = 3; k < 6; ++k) d->xfrc_applied[6 * b + k] = normal(rng, 0.05);
  }
  for (int i = 0; i < m->nv; ++i) {
    d->qfrc_applied[i] = normal(rng, 0.1);
    d->qacc_warmstart[i] = normal(rng, 1.0);
  }
}

// MuJoCo's inputs and state of one world into the engine's mirror
void put_world(const mjModel* m, const mjData* d, const World<double>& w) {
  std::copy(d->qpos, d->qpos + m->nq, w.qpos);
  std::copy(d->qvel, d->qvel + m->nv, w.qvel);
  std::copy(d->ctrl, d->ctrl + m->nu, w.ctrl);
  std::copy(d->xfrc_applied, d->xfrc_applied + 6 * m->nbody, w.xfrc_applied);
  std::copy(d->qfrc_applied, d->qfrc_applied + m->nv, w.qfrc_applied);
  std::copy(d->qacc_warmstart, d->qacc_warmstart + m->nv, w.qacc_warmstart);
  w.time[0] = d->time;
  w.fault[0] = 0;
}

bool sparse_jacobian(const mjModel* m) {
  return m->opt.jacobian == mjJAC_SPARSE || (m->opt.jacobian == mjJAC_AUTO && m->nv >= 60);
}

// MuJoCo's efc row r as a dense row
std::vector<double> mj_row(const mjModel* m, const mjData* d, int r) {
  std::vector<double> row(m->nv, 0.0);
  if (sparse_jacobian(m)) {
    for (int k = 0; k < d->efc_J_rownnz[r]; ++k)
      row[d->efc_J_colind[d->efc_J_rowadr[r] + k]] = d->efc_J[d->efc_J_rowadr[r] + k];
  } else {
    std::copy(d->efc_J + r * m->nv, d->efc_J + (r + 1) * m->nv, row.begin());
  }
  return row;
}

// every field that mj_forward computes, engine (mirror) against MuJoCo, world by world
void compare_forward(const mjModel* m, const ModelArrays& a, const std::vector<DataPtr>& ref,
                     HostData<double>& mirror, bool float32, Collector& col) {
  const int nv = m->nv, nb = m->nbody;
  for (size_t wi = 0; wi < ref.size(); ++wi) {
    const int w = static_cast<int>(wi);
    const mjData* d = ref[wi].get();
    const World<double> e = mirror.world(w);
    // mj_kinematics
    col.add("mj_kinematics", "qpos", e.qpos, d->qpos, m->nq, w);
    col.add("mj_kinematics", "xpos", e.xpos, d->xpos, 3 * nb, w);
    col.add("mj_kinematics", "xquat", e.xquat, d->xquat, 4 * nb, w);
    col.add("mj_kinematics", "xmat", e.xmat, d->xmat, 9 * nb, w);
    col.add("mj_kinematics", "xipos", e.xipos, d->xipos, 3 * nb, w);
    col.add("mj_kinematics", "ximat", e.ximat, d->ximat, 9 * nb, w);
    col.add("mj_kinematics", "xanchor", e.xanchor, d->xanchor, 3 * m->njnt, w);
    col.add("mj_kinematics", "xaxis", e.xaxis, d->xaxis, 3 * m->njnt, w);
    col.add("mj_kinematics", "geom_xpos", e.geom_xpos, d->geom_xpos, 3 * m->ngeom, w);
    col.add("mj_kinematics", "geom_xmat", e.geom_xmat, d->geom_xmat, 9 * m->ngeom, w);
    col.add("mj_kinematics", "site_xpos", e.site_xpos, d->site_xpos, 3 * m->nsite, w);
    col.add("mj_kinematics", "site_xmat", e.site_xmat, d->site_xmat, 9 * m->nsite, w);
    // mj_comPos (the world body's cinert is never written by MuJoCo)
    col.add("mj_comPos", "subtree_com", e.subtree_com, d->subtree_com, 3 * nb, w);
    col.add("mj_comPos", "cinert", e.cinert, d->cinert, 10 * nb, w, 10);
    col.add("mj_comPos", "cdof", e.cdof, d->cdof, 6 * nv, w);
    if (m->ntendon) col.add("mj_tendon", "ten_length", e.ten_length, d->ten_length, m->ntendon, w);
    // mj_crb, mj_factorM
    col.add("mj_crb", "crb", e.crb, d->crb, 10 * nb, w, 10);
    col.add("mj_crb", "qM", e.qM, d->qM, m->nM, w);
    col.add("mj_factorM", "qLD", e.qLD, d->qLD, m->nM, w);
    col.add("mj_factorM", "qLDiagInv", e.qLDiagInv, d->qLDiagInv, nv, w);
    // mj_transmission: lengths, and the (constant) moments as a dense nu x nv matrix
    col.add("mj_transmission", "actuator_length", e.actuator_length, d->actuator_length, m->nu, w);
    std::vector<double> moment(static_cast<size_t>(m->nu) * nv, 0.0);
    for (int u = 0; u < m->nu; ++u)
      for (int k = a.act_adr[u]; k < a.act_adr[u + 1]; ++k)
        moment[static_cast<size_t>(u) * nv + a.act_dof[k]] += a.act_moment[k];
    col.add("mj_transmission", "actuator_moment", moment.data(), d->actuator_moment, m->nu * nv, w);
    // mj_fwdVelocity and its parts
    if (m->ntendon)
      col.add("mj_fwdVelocity", "ten_velocity", e.ten_velocity, d->ten_velocity, m->ntendon, w);
    col.add("mj_fwdVelocity", "actuator_velocity", e.actuator_velocity, d->actuator_velocity,
            m->nu, w);
    col.add("mj_comVel", "cvel", e.cvel, d->cvel, 6 * nb, w);
    col.add("mj_comVel", "cdof_dot", e.cdof_dot, d->cdof_dot, 6 * nv, w);
    col.add("mj_passive", "qfrc_passive", e.qfrc_passive, d->qfrc_passive, nv, w);
    col.add("mj_rne", "qfrc_bias", e.qfrc_bias, d->qfrc_bias, nv, w);
    // mj_fwdActuation, mj_fwdAcceleration
    col.add("mj_fwdActuation", "actuator_force", e.actuator_force, d->actuator_force, m->nu, w);
    col.add("mj_fwdActuation", "qfrc_actuator", e.qfrc_actuator, d->qfrc_actuator, nv, w);
    col.add("mj_fwdAcceleration", "qfrc_smooth", e.qfrc_smooth, d->qfrc_smooth, nv, w);
    col.add("mj_fwdAcceleration", "qacc_smooth", e.qacc_smooth, d->qacc_smooth, nv, w);

    // constraint rows: the engine's active candidates in order are MuJoCo's rows
    std::vector<int> rows;
    int ne = 0, nf = 0;
    for (int c = 0; c < a.s.ncand; ++c) {
      if (!e.efc_active[c]) continue;
      rows.push_back(c);
      if (a.cand_kind[c] == kCandEqJoint || a.cand_kind[c] == kCandEqTendon) ++ne;
      if (a.cand_kind[c] == kCandFrictionDof || a.cand_kind[c] == kCandFrictionTendon) ++nf;
    }
    col.exact("mj_makeConstraint", "nefc", static_cast<long>(rows.size()), d->nefc, w, 0);
    col.exact("mj_makeConstraint", "ne", ne, d->ne, w, 0);
    col.exact("mj_makeConstraint", "nf", nf, d->nf, w, 0);
    if (static_cast<int>(rows.size()) == d->nefc) {
      for (int r = 0; r < d->nefc; ++r) {
        const int c = rows[r];
        col.exact("mj_makeConstraint", "efc_type", a.cand_type[c], d->efc_type[r], w, r);
        col.exact("mj_makeConstraint", "efc_id", a.cand_id[c], d->efc_id[r], w, r);
        std::vector<double> row(nv, 0.0);
        for (int k = a.cand_adr[c]; k < a.cand_adr[c + 1]; ++k) row[a.cand_dof[k]] = e.efc_J[k];
        const std::vector<double> ref_row = mj_row(m, d, r);
        col.add("mj_makeConstraint", "efc_J", row.data(), ref_row.data(), nv, w);
        col.add_value("mj_makeConstraint", "efc_pos", e.efc_pos[c], d->efc_pos[r], w, r);
        col.add_value("mj_makeConstraint", "efc_margin", a.cand_margin[c], d->efc_margin[r], w, r);
        col.add_value("mj_makeConstraint", "efc_frictionloss", a.cand_floss[c],
                      d->efc_frictionloss[r], w, r);
        col.add_value("mj_makeConstraint", "efc_R", e.efc_R[c], d->efc_R[r], w, r);
        col.add_value("mj_makeConstraint", "efc_D", e.efc_D[c], d->efc_D[r], w, r);
        col.add_value("mj_referenceConstraint", "efc_vel", e.efc_vel[c], d->efc_vel[r], w, r);
        col.add_value("mj_referenceConstraint", "efc_aref", e.efc_aref[c], d->efc_aref[r], w, r);
        col.add_value("mj_fwdConstraint", "efc_force", e.efc_force[c], d->efc_force[r], w, r);
        // float32 rounding moves friction rows that sit at the edge of their quadratic zone
        // (|jar| = R frictionloss) across it; their forces are compared above
        if (!float32)
          col.exact("mj_fwdConstraint", "efc_state", e.efc_state[c], d->efc_state[r], w, r);
      }
    }
    col.add("mj_fwdConstraint", "qacc", e.qacc, d->qacc, nv, w);
    col.add("mj_fwdConstraint", "qfrc_constraint", e.qfrc_constraint, d->qfrc_constraint, nv, w);
    col.add("mj_fwdConstraint", "qacc_warmstart", e.qacc_warmstart, d->qacc_warmstart, nv, w);
  }
}

// Features the two-hand scene does not use: springs, a limited ball joint, a welded body, fixed
// tendons (spring, damper, friction, limits, an equality between two tendons, an actuator),
// a polynomial joint coupling, affine gain and bias, a velocity servo, a motor with gear.
const char* const kFeatures = R"(
<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.002"><flag contact="disable"/></option>
  <worldbody>
    <body name="base" pos="0 0 1">
      <joint name="s0" type="slide" axis="1 0 0" range="-0.1 0.1" limited="true" damping="1"/>
      <geom type="box" size="0.1 0.05 0.05" mass="1"/>
      <body name="arm" pos="0.1 0 0">
        <joint name="h1" axis="0 1 0" stiffness="2" springref="0.3" damping="0.1"
               armature="0.01" range="-1 1" limited="true" frictionloss="0.05"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.2"/>
        <body name="welded" pos="0.2 0 0" quat="0.9 0.1 0.3 0">
          <geom type="sphere" size="0.03" mass="0.1" pos="0.01 0 0"/>
          <site name="tip" pos="0.02 0.01 0" quat="0.7 0 0.7 0"/>
          <body name="wrist" pos="0.05 0 0">
            <joint name="b2" type="ball" range="0 0.5" limited="true" damping="0.05"
                   stiffness="0.5"/>
            <geom type="box" size="0.03 0.02 0.01" pos="0.03 0 0" mass="0.05"/>
            <body name="f1" pos="0.06 0 0">
              <joint name="h3" axis="0 0 1" range="-0.5 1.2" limited="true" damping="0.02"/>
              <geom type="capsule" fromto="0 0 0 0.05 0 0" size="0.01" mass="0.02"/>
              <body name="f2" pos="0.05 0 0">
                <joint name="h4" axis="0 0 1" range="0 1.5" limited="true" damping="0.02"/>
                <geom type="capsule" fromto="0 0 0 0.04 0 0" size="0.008" mass="0.01"/>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
    <body name="egg" pos="0.5 0.5 1">
      <freejoint/>
      <geom type="ellipsoid" size="0.03 0.04 0.05" mass="0.1"/>
    </body>
  </worldbody>
  <tendon>
    <fixed name="t1" limited="true" range="-0.3 0.6" frictionloss="0.02" stiffness="1"
           damping="0.1" springlength="0.1">
      <joint joint="h3" coef="1"/>
      <joint joint="h4" coef="0.5"/>
    </fixed>
    <fixed name="t2"><joint joint="h1" coef="1"/></fixed>
  </tendon>
  <equality>
    <joint joint1="h4" joint2="h3" polycoef="0.1 0.8 0.2 0.1 0" solref="0.01 1"/>
    <tendon tendon1="t1" tendon2="t2" polycoef="0 0.5 0 0 0"/>
  </equality>
  <actuator>
    <position joint="s0" kp="50" ctrlrange="-0.1 0.1" forcerange="-5 5" forcelimited="true"
              ctrllimited="true"/>
    <motor joint="h1" gear="2" ctrlrange="-1 1" ctrllimited="true"/>
    <motor tendon="t1" ctrlrange="-1 1" ctrllimited="true"/>
    <general joint="h3" gaintype="affine" gainprm="1 0.5 0.1" biastype="affine"
             biasprm="0 -2 -0.1"/>
    <velocity joint="h4" kv="0.1"/>
  </actuator>
</mujoco>)";

}  // namespace

const char* features_mjcf() { return kFeatures; }

bool ParityReport::pass() const {
  if (fields.empty()) return false;
  for (const FieldCheck& f : fields)
    if (!f.pass()) return false;
  return true;
}

std::string ParityReport::table() const {
  std::ostringstream o;
  o << engine << ", " << check << " (" << seconds << " s)\n";
  char line[256];
  for (const FieldCheck& f : fields) {
    std::snprintf(line, sizeof line, "  %-22s %-18s %7ld  max|err| %-10.3g ratio %-10.3g %s\n",
                  f.stage.c_str(), f.field.c_str(), f.count, f.max_abs, f.max_ratio,
                  f.pass() ? "PASS" : "FAIL");
    o << line;
  }
  return o.str();
}

std::string ParityReport::failures() const {
  std::ostringstream o;
  for (const FieldCheck& f : fields)
    if (!f.pass())
      o << engine << " " << check << ": " << f.stage << " " << f.field << ": " << f.mismatched
        << " of " << f.count << " values outside the tolerance (atol " << f.tol.atol
        << ", rtol " << f.tol.rtol << ", of_max " << f.tol.of_max << "); worst " << f.worst
        << "\n";
  return o.str();
}

Tolerance stage_tolerance(const std::string& stage, bool float32) {
  // float64: most stages agree to the last bits (sim/gpu/README.md has the measured errors); the
  // constrained acceleration of these random states (violated limits and couplings, |qacc| up
  // to 1e5) is ill-conditioned, so qacc and the forces agree to ~1e-8 of their largest values
  // however tight MuJoCo's tolerance is, and one step's qvel to h times that.
  // float32: single-precision rounding through the same pipeline; R = (1-imp)/imp diagApprox
  // loses digits as imp nears 1 (relative 1e-4 at imp 0.999); the same conditioning makes the
  // solver's outputs good to ~1e-3 of their largest value and one step's qvel to h times that.
  struct Row {
    const char* stage;
    Tolerance f64, f32;
  };
  static const Row rows[] = {
      {"mj_kinematics", {1e-12, 0, 0}, {2e-5, 0, 0}},
      {"mj_comPos", {1e-12, 1e-12, 0}, {2e-5, 1e-5, 0}},
      {"mj_tendon", {1e-12, 0, 0}, {2e-5, 0, 0}},
      {"mj_crb", {1e-14, 1e-12, 0}, {0, 1e-5, 1e-6}},
      {"mj_factorM", {0, 1e-10, 1e-12}, {0, 1e-2, 1e-4}},
      {"mj_transmission", {1e-12, 0, 0}, {1e-5, 0, 0}},
      {"mj_fwdVelocity", {1e-12, 1e-10, 0}, {1e-5, 1e-4, 0}},
      {"mj_comVel", {1e-12, 1e-10, 0}, {1e-5, 1e-4, 0}},
      {"mj_passive", {1e-12, 1e-10, 0}, {1e-5, 1e-5, 0}},
      {"mj_rne", {1e-12, 1e-10, 1e-12}, {0, 1e-4, 1e-5}},
      {"mj_fwdActuation", {1e-12, 1e-12, 0}, {1e-6, 1e-5, 0}},
      {"mj_fwdAcceleration", {0, 1e-9, 1e-11}, {0, 1e-3, 1e-4}},
      {"mj_makeConstraint", {1e-12, 1e-10, 0}, {1e-5, 5e-4, 0}},
      {"mj_referenceConstraint", {1e-12, 1e-10, 0}, {1e-5, 5e-4, 1e-5}},
      {"mj_fwdConstraint", {0, 1e-6, 1e-6}, {0, 1e-2, 1e-2}},
      {"mj_Euler", {1e-9, 1e-8, 1e-6}, {1e-4, 1e-3, 2e-2}},
      {"trajectory", {1e-7, 0, 0}, {1e-3, 0, 0}},
      {"trajectory_qvel", {1e-5, 0, 0}, {1e-1, 0, 0}},
  };
  for (const Row& r : rows)
    if (stage == r.stage) return float32 ? r.f32 : r.f64;
  return float32 ? Tolerance{1e-4, 1e-4, 0} : Tolerance{1e-10, 1e-10, 0};
}

mjModel* contact_free_copy(const mjModel* m) {
  mjModel* c = mj_copyModel(nullptr, m);
  c->opt.disableflags |= mjDSBL_CONTACT;
  return c;
}

// one MuJoCo reference per world of `engine`, each in a random state that is also put into the
// engine's world and uploaded
static std::vector<DataPtr> random_worlds(const mjModel* m, Engine& engine, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<DataPtr> ref;
  for (int w = 0; w < engine.nworld(); ++w) {
    ref.emplace_back(mj_makeData(m));
    random_state(m, rng, ref.back().get());
    put_world(m, ref.back().get(), engine.mirror().world(w));
  }
  engine.upload();
  return ref;
}

ParityReport check_forward(const mjModel* m, const ModelArrays& arrays, Engine& engine,
                           uint64_t seed, bool float32) {
  ParityReport rep;
  rep.engine = engine.describe();
  rep.check = "forward";
  const double t0 = seconds_now();
  std::vector<DataPtr> ref = random_worlds(m, engine, seed);
  engine.forward();
  engine.download();
  for (auto& d : ref) mj_forward(m, d.get());
  Collector col(float32);
  compare_forward(m, arrays, ref, engine.mirror(), float32, col);
  rep.fields = col.finish();
  rep.seconds = seconds_now() - t0;
  return rep;
}

ParityReport check_step(const mjModel* m, const ModelArrays& arrays, Engine& engine,
                        uint64_t seed, bool float32) {
  ParityReport rep;
  rep.engine = engine.describe();
  rep.check = "step";
  const double t0 = seconds_now();
  std::vector<DataPtr> ref = random_worlds(m, engine, seed);
  engine.step(1);
  engine.download();
  Collector col(float32);
  for (int w = 0; w < engine.nworld(); ++w) {
    mjData* d = ref[w].get();
    mj_step(m, d);
    const World<double> e = engine.mirror().world(w);
    col.add("mj_Euler", "qpos", e.qpos, d->qpos, m->nq, w);
    col.add("mj_Euler", "qvel", e.qvel, d->qvel, m->nv, w);
    col.add("mj_Euler", "time", e.time, &d->time, 1, w);
    col.add("mj_fwdConstraint", "qacc", e.qacc, d->qacc, m->nv, w);
    col.exact("mj_Euler", "fault", e.fault[0], 0, w, 0);
  }
  rep.fields = col.finish();
  rep.seconds = seconds_now() - t0;
  (void)arrays;
  return rep;
}

ParityReport check_trajectory(const mjModel* m, const ModelArrays& arrays, Engine& engine,
                              uint64_t seed, bool float32, double seconds, int hold,
                              const std::vector<double>& xfrc) {
  ParityReport rep;
  rep.engine = engine.describe();
  rep.check = "trajectory";
  const double t0 = seconds_now();
  const int nworld = engine.nworld();
  std::vector<std::mt19937_64> rng;
  std::vector<DataPtr> ref;
  for (int w = 0; w < nworld; ++w) {
    rng.emplace_back(seed * 1000003 + w);
    ref.emplace_back(mj_makeData(m));
    mjData* d = ref.back().get();
    mj_resetData(m, d);
    for (int i = 0; i < m->nv; ++i) d->qvel[i] = normal(rng[w], 0.1);
    if (!xfrc.empty()) std::copy(xfrc.begin(), xfrc.end(), d->xfrc_applied);
  }
  const int periods =
      std::max(1, static_cast<int>(std::lround(seconds / (m->opt.timestep * hold))));
  Collector col(float32);
  for (int p = 0; p < periods; ++p) {
    // new random targets, the same in both
    for (int w = 0; w < nworld; ++w) {
      mjData* d = ref[w].get();
      for (int u = 0; u < m->nu; ++u) {
        const double lo = m->actuator_ctrllimited[u] ? m->actuator_ctrlrange[2 * u] : -1.0;
        const double hi = m->actuator_ctrllimited[u] ? m->actuator_ctrlrange[2 * u + 1] : 1.0;
        d->ctrl[u] = uniform(rng[w], lo, hi);
      }
      if (p == 0) {
        put_world(m, d, engine.mirror().world(w));
      } else {
        std::copy(d->ctrl, d->ctrl + m->nu, engine.mirror().world(w).ctrl);
      }
    }
    engine.upload();
    engine.step(hold);
    engine.download();
    for (int w = 0; w < nworld; ++w) {
      mjData* d = ref[w].get();
      for (int k = 0; k < hold; ++k) mj_step(m, d);
      const World<double> e = engine.mirror().world(w);
      col.add("trajectory", "qpos", e.qpos, d->qpos, m->nq, w);
      col.add("trajectory_qvel", "qvel", e.qvel, d->qvel, m->nv, w);
      col.exact("trajectory", "fault", e.fault[0], 0, w, p);
    }
  }
  rep.fields = col.finish();
  rep.seconds = seconds_now() - t0;
  (void)arrays;
  return rep;
}

}  // namespace bidex::sim::gpu
