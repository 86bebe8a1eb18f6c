// The pipeline of one world, in MuJoCo 2.2.2's order (mj_forward, then mj_Euler):
//   forward  = kinematics, com_pos, tendon, crb, factor_m, make_constraint, transmission,
//              fwd_velocity (tendon/actuator velocities, com_vel, passive,
//              reference_constraint, rne), fwd_actuation, fwd_acceleration, fwd_constraint
//   euler    = qacc with implicit joint damping ((M + h diag(damping))^-1 (qfrc_smooth +
//              qfrc_constraint)), qvel += h qacc, qpos integrated with the new qvel, time += h
//   step     = forward + euler, then the world's health check
// Each stage is also callable alone (tests and the GPU parity check time and compare them).
#pragma once

#include "sim/gpu/constraint.h"

namespace bidex::sim::gpu {

// Velocity-dependent quantities (mj_fwdVelocity).
template <class T>
BIDEX_HD void fwd_velocity(const Model<T>& m, const World<T>& d, Lanes ln) {
  for (int t = ln.id; t < m.s.ntendon; t += ln.n) {
    T v = 0;
    for (int k = m.ten_adr[t]; k < m.ten_adr[t + 1]; ++k) v += m.ten_coef[k] * d.qvel[m.ten_dof[k]];
    d.ten_velocity[t] = v;
  }
  for (int a = ln.id; a < m.s.nu; a += ln.n) {
    T v = 0;
    for (int k = m.act_adr[a]; k < m.act_adr[a + 1]; ++k)
      v += m.act_moment[k] * d.qvel[m.act_dof[k]];
    d.actuator_velocity[a] = v;
  }
  ln.sync();
  com_vel(m, d, ln);
  passive(m, d, ln);
  reference_constraint(m, d, ln);
  rne(m, d, ln);
}

// Position stages (mj_fwdPosition without collision). `poses`: also geom and site poses.
template <class T>
BIDEX_HD void fwd_position(const Model<T>& m, const World<T>& d, Lanes ln, bool poses = true) {
  kinematics(m, d, ln, poses);
  com_pos(m, d, ln);
  tendon(m, d, ln);
  crb(m, d, ln);
  factor_m(m, d, ln);
  make_constraint(m, d, ln);
  transmission(m, d, ln);
}

// Everything up to the constrained acceleration (mj_forward without sensors).
template <class T>
BIDEX_HD void forward(const Model<T>& m, const World<T>& d, Lanes ln, bool poses = true) {
  fwd_position(m, d, ln, poses);
  fwd_velocity(m, d, ln);
  fwd_actuation(m, d, ln);
  fwd_acceleration(m, d, ln);
  fwd_constraint(m, d, ln);
}

// qpos advanced by qvel over h (quaternions by their local angular velocity).
template <class T>
BIDEX_HD void integrate_pos(const Model<T>& m, const World<T>& d, T h, Lanes ln) {
  for (int j = ln.id; j < m.s.njnt; j += ln.n) {
    T* q = d.qpos + m.jnt_qposadr[j];
    const T* v = d.qvel + m.jnt_dofadr[j];
    switch (m.jnt_type[j]) {
      case kJointFree:
        for (int c = 0; c < 3; ++c) q[c] += h * v[c];
        quat_integrate(q + 3, v + 3, h);
        break;
      case kJointBall:
        quat_integrate(q, v, h);
        break;
      default:
        q[0] += h * v[0];
    }
  }
  ln.sync();
}

// Semi-implicit Euler with implicit joint damping (mj_Euler of 2.2.2).
template <class T>
BIDEX_HD void euler(const Model<T>& m, const World<T>& d, Lanes ln) {
  const T h = m.opt.timestep;
  const T* qacc = d.qacc;
  if (m.opt.implicit_damping) {
    // (M + h diag(damping)) qacc = qfrc_smooth + qfrc_constraint
    for (int e = ln.id; e < m.s.nM; e += ln.n) d.qH[e] = d.qM[e];
    ln.sync();
    for (int i = ln.id; i < m.s.nv; i += ln.n) {
      d.qH[m.dof_Madr[i]] += h * m.dof_damping[i];
      d.qacc_euler[i] = d.qfrc_smooth[i] + d.qfrc_constraint[i];
    }
    ln.sync();
    if (factor_ld(m, d.qH, d.qH, d.qHDiagInv, ln) && ln.id == 0) d.fault[0] |= kGpuFaultInertia;
    solve_ld(m, d.qH, d.qHDiagInv, d.qacc_euler, d.qacc_euler, ln);
    qacc = d.qacc_euler;
  }
  for (int i = ln.id; i < m.s.nv; i += ln.n) d.qvel[i] += h * qacc[i];
  ln.sync();
  integrate_pos(m, d, h, ln);
  if (ln.id == 0) d.time[0] += h;
  ln.sync();
}

// Sets kGpuFaultNonFinite when qpos, qvel or qacc holds a NaN or infinity.
template <class T>
BIDEX_HD void check_finite(const Model<T>& m, const World<T>& d, Lanes ln) {
  int bad = 0;
  for (int i = ln.id; i < m.s.nq; i += ln.n) bad |= !g_finite(d.qpos[i]);
  for (int i = ln.id; i < m.s.nv; i += ln.n) bad |= !g_finite(d.qvel[i]) || !g_finite(d.qacc[i]);
  bad = ln.max(bad);
  if (bad && ln.id == 0) d.fault[0] |= kGpuFaultNonFinite;
  ln.sync();
}

// One physics step of one world (mj_step with the Euler integrator, no collision).
template <class T>
BIDEX_HD void step(const Model<T>& m, const World<T>& d, Lanes ln, bool poses = false) {
  forward(m, d, ln, poses);
  euler(m, d, ln);
  check_finite(m, d, ln);
}

}  // namespace bidex::sim::gpu
