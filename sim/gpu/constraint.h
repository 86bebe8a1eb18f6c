// Joint limits, friction loss and joint/tendon equality coupling as MuJoCo-style soft
// constraints, and the solver for the constrained acceleration:
//   make_constraint       mj_makeConstraint     rows: violation, Jacobian, impedance, R, D
//   reference_constraint  mj_referenceConstraint efc_vel, efc_aref (from solref/solimp)
//   fwd_constraint        mj_fwdConstraint      warm start and Newton's method on MuJoCo's
//                                                convex cost: qacc, efc_force, qfrc_constraint
//
// Rows are the model's constraint candidates (ModelArrays), indexed by candidate: a limit row
// exists in every world and is "active" only where the limit is reached, so there is no
// per-world compaction and no atomic counter; the active candidates in candidate order are
// exactly MuJoCo's efc rows in MuJoCo's order. Every row's dofs lie on one kinematic chain, so
// the Newton Hessian M + J'DJ has the mass matrix's tree sparsity and is factored by the same
// L'DL as M (factor_ld): no dense nv x nv work.
//
// The solver reaches the unique minimiser of the same strictly convex cost as MuJoCo's Newton
// solver and stops by MuJoCo's rules (scaled improvement or gradient below the tolerance, or the
// iteration cap); its line search is its own (a safeguarded Newton search on the piecewise
// quadratic cost), so iterates may differ on the way while the solution agrees to the tolerance.
#pragma once

#include "sim/gpu/smooth.h"

namespace bidex::sim::gpu {

// MuJoCo's impedance of a row at violation `pos` (getimpedance, value only).
template <class T>
BIDEX_HD inline T impedance(const T* solimp, T pos, T margin) {
  if (solimp[0] == solimp[1] || solimp[2] <= T(kMinVal)) return T(0.5) * (solimp[0] + solimp[1]);
  T x = (pos - margin) / solimp[2];
  if (x < 0) x = -x;
  if (x >= 1 || x <= 0) return x >= 1 ? solimp[1] : solimp[0];
  T y;
  if (solimp[4] == 1) {
    y = x;
  } else if (x <= solimp[3]) {
    const T a = T(1) / g_pow(solimp[3], solimp[4] - 1);
    y = a * g_pow(x, solimp[4]);
  } else {
    const T b = T(1) / g_pow(1 - solimp[3], solimp[4] - 1);
    y = 1 - b * g_pow(1 - x, solimp[4]);
  }
  return solimp[0] + y * (solimp[1] - solimp[0]);
}

// Which candidates are active, their violation, Jacobian, impedance, R and D.
template <class T>
BIDEX_HD void make_constraint(const Model<T>& m, const World<T>& d, Lanes ln) {
  for (int c = ln.id; c < m.s.ncand; c += ln.n) {
    const int kind = m.cand_kind[c];
    const int a0 = m.cand_adr[c], a1 = m.cand_adr[c + 1];
    const int o1 = m.cand_obj[2 * c], o2 = m.cand_obj[2 * c + 1];
    const T* prm = m.cand_prm + 5 * c;
    T pos = 0;
    int active = 1;
    if (kind == kCandEqJoint || kind == kCandEqTendon) {
      // q1 - ref1 - (data0 + data1 dif + ... + data4 dif^4), dif = q2 - ref2
      const bool joint = kind == kCandEqJoint;
      const T p1 = joint ? d.qpos[m.jnt_qposadr[o1]] : d.ten_length[o1];
      T deriv = 0;
      if (o2 >= 0) {
        const T p2 = joint ? d.qpos[m.jnt_qposadr[o2]] : d.ten_length[o2];
        const T dif = p2 - m.cand_ref[2 * c + 1];
        pos = p1 - m.cand_ref[2 * c] - prm[0] -
              (prm[1] * dif + prm[2] * dif * dif + prm[3] * dif * dif * dif +
               prm[4] * dif * dif * dif * dif);
        deriv = prm[1] + 2 * prm[2] * dif + 3 * prm[3] * dif * dif + 4 * prm[4] * dif * dif * dif;
      } else {
        pos = p1 - m.cand_ref[2 * c] - prm[0];
      }
      for (int a = a0; a < a1; ++a) d.efc_J[a] = m.cand_c1[a] - deriv * m.cand_c2[a];
    } else if (kind == kCandFrictionDof || kind == kCandFrictionTendon) {
      for (int a = a0; a < a1; ++a) d.efc_J[a] = m.cand_c1[a];
    } else if (kind == kCandLimitBall) {
      // rotation angle against the larger range bound; J along the rotation axis
      T aa[3];
      quat_to_vel(aa, d.qpos + m.jnt_qposadr[o1]);
      const T angle = normalize3(aa);
      pos = prm[0] - angle;
      active = pos < m.cand_margin[c];
      for (int k = 0; k < 3; ++k) d.efc_J[a0 + k] = -aa[k];
    } else {
      // lower (side -1) or upper (side +1) limit of a joint or tendon
      const T side = (kind == kCandLimitLow || kind == kCandTendonLow) ? T(-1) : T(1);
      const bool joint = kind == kCandLimitLow || kind == kCandLimitHigh;
      const T value = joint ? d.qpos[m.jnt_qposadr[o1]] : d.ten_length[o1];
      pos = side * (prm[0] - value);
      active = pos < m.cand_margin[c];
      for (int a = a0; a < a1; ++a) d.efc_J[a] = m.cand_c1[a];
    }
    d.efc_active[c] = active;
    d.efc_pos[c] = pos;
    // regularisation from the impedance: R = (1 - imp) / imp * diagApprox
    const T imp = impedance(m.cand_solimp + 5 * c, pos, m.cand_margin[c]);
    const T R = g_max(T(kMinVal), (1 - imp) * m.cand_diag[c] / imp);
    d.efc_imp[c] = imp;
    d.efc_R[c] = R;
    d.efc_D[c] = T(1) / R;
  }
  ln.sync();
}

// J x for one candidate row
template <class T>
BIDEX_HD inline T row_dot(const Model<T>& m, const World<T>& d, int c, const T* x) {
  T r = 0;
  for (int a = m.cand_adr[c]; a < m.cand_adr[c + 1]; ++a) r += d.efc_J[a] * x[m.cand_dof[a]];
  return r;
}

// Constraint velocity and reference acceleration aref = -B vel - K imp (pos - margin).
template <class T>
BIDEX_HD void reference_constraint(const Model<T>& m, const World<T>& d, Lanes ln) {
  for (int c = ln.id; c < m.s.ncand; c += ln.n) {
    const T vel = row_dot(m, d, c, d.qvel);
    d.efc_vel[c] = vel;
    const T violation = d.efc_pos[c] - m.cand_margin[c];
    d.efc_aref[c] = -m.cand_B[c] * vel - m.cand_K[c] * d.efc_imp[c] * violation;
  }
  ln.sync();
}

// Cost of one active row at jar = x, and its state and force (MuJoCo's mj_constraintUpdate).
template <class T>
BIDEX_HD inline T row_update(const Model<T>& m, const World<T>& d, int c, T x, int* state,
                             T* force) {
  const int kind = m.cand_kind[c];
  const T D = d.efc_D[c];
  if (kind == kCandFrictionDof || kind == kCandFrictionTendon) {
    const T f = m.cand_floss[c], Rf = d.efc_R[c] * f;
    if (x <= -Rf) {
      *state = kStateLinearNeg;
      *force = f;
      return -T(0.5) * d.efc_R[c] * f * f - f * x;
    }
    if (x >= Rf) {
      *state = kStateLinearPos;
      *force = -f;
      return -T(0.5) * d.efc_R[c] * f * f + f * x;
    }
  } else if (kind != kCandEqJoint && kind != kCandEqTendon && x >= 0) {
    *state = kStateSatisfied;
    *force = 0;
    return 0;
  }
  *state = kStateQuadratic;
  *force = -D * x;
  return T(0.5) * D * x * x;
}

// Gauss cost 0.5 (M qacc - qfrc_smooth) . (qacc - qacc_smooth), summed over the lanes.
template <class T>
BIDEX_HD T gauss_cost(const Model<T>& m, const World<T>& d, const T* Ma, const T* qacc,
                      Lanes ln) {
  T s = 0;
  for (int i = ln.id; i < m.s.nv; i += ln.n)
    s += T(0.5) * (Ma[i] - d.qfrc_smooth[i]) * (qacc[i] - d.qacc_smooth[i]);
  return ln.sum(s);
}

// States, forces and qfrc_constraint at jar = efc_jar; returns the constraint cost and counts
// the rows whose state changed.
template <class T>
BIDEX_HD T update_constraint(const Model<T>& m, const World<T>& d, Lanes ln, int* nchange) {
  T cost = 0;
  int changed = 0;
  for (int c = ln.id; c < m.s.ncand; c += ln.n) {
    if (!d.efc_active[c]) continue;
    int state;
    T force;
    cost += row_update(m, d, c, d.efc_jar[c], &state, &force);
    changed += state != d.efc_state[c];
    d.efc_state[c] = state;
    d.efc_force[c] = force;
  }
  ln.sync();
  // qfrc_constraint = J' force, by dof in row order
  for (int i = ln.id; i < m.s.nv; i += ln.n) {
    T r = 0;
    for (int e = m.dof_candadr[i]; e < m.dof_candadr[i + 1]; ++e) {
      const int a = m.dof_candent[e];
      const int c = m.nnz_cand[a];
      if (d.efc_active[c]) r += d.efc_J[a] * d.efc_force[c];
    }
    d.qfrc_constraint[i] = r;
  }
  ln.sync();
  if (nchange) *nchange = ln.sum(changed);
  return ln.sum(cost);
}

// Hessian M + J' D J over the quadratic rows, factored in qH.
template <class T>
BIDEX_HD void hessian(const Model<T>& m, const World<T>& d, Lanes ln) {
  for (int e = ln.id; e < m.s.nM; e += ln.n) d.qH[e] = d.qM[e];
  ln.sync();
  for (int h = ln.id; h < m.s.nhent; h += ln.n) {
    T add = 0;
    for (int k = m.hent_adr[h]; k < m.hent_adr[h + 1]; ++k) {
      const int a = m.hcon_a[k], b = m.hcon_b[k];
      const int c = m.nnz_cand[a];
      if (d.efc_active[c] && d.efc_state[c] == kStateQuadratic)
        add += d.efc_D[c] * d.efc_J[a] * d.efc_J[b];
    }
    d.qH[m.hent_addr[h]] += add;
  }
  ln.sync();
  factor_ld(m, d.qH, d.qH, d.qHDiagInv, ln);
}

// grad = M qacc - qfrc_smooth - qfrc_constraint and search = -H^-1 grad; returns |grad|.
template <class T>
BIDEX_HD T gradient(const Model<T>& m, const World<T>& d, Lanes ln) {
  T g2 = 0;
  for (int i = ln.id; i < m.s.nv; i += ln.n) {
    const T g = d.sol_Ma[i] - d.qfrc_smooth[i] - d.qfrc_constraint[i];
    d.sol_grad[i] = g;
    g2 += g * g;
  }
  ln.sync();
  solve_ld(m, d.qH, d.qHDiagInv, d.sol_search, d.sol_grad, ln);
  for (int i = ln.id; i < m.s.nv; i += ln.n) d.sol_search[i] = -d.sol_search[i];
  ln.sync();
  return g_sqrt(ln.sum(g2));
}

// a point of the line search: step, cost, first and second derivatives
template <class T>
struct LinePoint {
  T alpha = 0, cost = 0, d1 = 0, d2 = 0;
};

// cost along qacc + alpha search (gauss: the Gauss cost's polynomial coefficients)
template <class T>
BIDEX_HD LinePoint<T> line_eval(const Model<T>& m, const World<T>& d, const T* gauss, T alpha,
                                Lanes ln) {
  T c0 = 0, c1 = 0, c2 = 0;
  for (int c = ln.id; c < m.s.ncand; c += ln.n) {
    if (!d.efc_active[c]) continue;
    const T jv = d.efc_jv[c], x = d.efc_jar[c] + alpha * jv, D = d.efc_D[c];
    const int kind = m.cand_kind[c];
    if (kind == kCandFrictionDof || kind == kCandFrictionTendon) {
      const T f = m.cand_floss[c], Rf = d.efc_R[c] * f;
      if (x <= -Rf) {
        c0 += f * (-T(0.5) * Rf - x);
        c1 += -f * jv;
        continue;
      }
      if (x >= Rf) {
        c0 += f * (-T(0.5) * Rf + x);
        c1 += f * jv;
        continue;
      }
    } else if (kind != kCandEqJoint && kind != kCandEqTendon && x >= 0) {
      continue;
    }
    c0 += T(0.5) * D * x * x;
    c1 += D * x * jv;
    c2 += D * jv * jv;
  }
  LinePoint<T> p;
  p.alpha = alpha;
  p.cost = ln.sum(c0) + gauss[0] + alpha * (gauss[1] + alpha * gauss[2]);
  p.d1 = ln.sum(c1) + gauss[1] + 2 * alpha * gauss[2];
  p.d2 = ln.sum(c2) + 2 * gauss[2];
  if (p.d2 <= 0) p.d2 = T(kMinVal);
  return p;
}

// Step length along sol_search that minimises the cost (0: no improvement). Fills sol_Mv and
// efc_jv. The cost is convex and piecewise quadratic in alpha: Newton steps on it, kept inside
// the bracket of sign changes of the slope, end on the exact minimiser of a piece.
template <class T>
BIDEX_HD T line_search(const Model<T>& m, const World<T>& d, T gauss0, Lanes ln) {
  T sn = 0;
  for (int i = ln.id; i < m.s.nv; i += ln.n) sn += d.sol_search[i] * d.sol_search[i];
  const T snorm = g_sqrt(ln.sum(sn));
  if (snorm < T(kMinVal)) return 0;
  const T scale = m.opt.meaninertia * T(m.s.nv > 1 ? m.s.nv : 1);
  const T gtol = m.opt.tolerance * T(0.01) * snorm * scale;

  // M search, J search, and the Gauss polynomial
  mul_m(m, d.qM, d.sol_search, d.sol_Mv, ln);
  for (int c = ln.id; c < m.s.ncand; c += ln.n)
    d.efc_jv[c] = d.efc_active[c] ? row_dot(m, d, c, d.sol_search) : T(0);
  T q1 = 0, q2 = 0;
  for (int i = ln.id; i < m.s.nv; i += ln.n) {
    q1 += d.sol_search[i] * (d.sol_Ma[i] - d.qfrc_smooth[i]);
    q2 += d.sol_search[i] * d.sol_Mv[i];
  }
  ln.sync();
  const T gauss[3] = {gauss0, ln.sum(q1), T(0.5) * ln.sum(q2)};

  const LinePoint<T> p0 = line_eval(m, d, gauss, T(0), ln);
  if (!(p0.d1 < 0)) return 0;  // not a descent direction (converged to rounding)
  LinePoint<T> lo = p0, hi, best = p0, p = line_eval(m, d, gauss, -p0.d1 / p0.d2, ln);
  bool has_hi = false;
  for (int it = 0; it < 50; ++it) {
    if (p.cost < best.cost) best = p;
    if (g_abs(p.d1) < gtol) break;
    if (p.d1 < 0) {
      lo = p;
    } else {
      hi = p;
      has_hi = true;
    }
    T next = p.alpha - p.d1 / p.d2;
    if (has_hi && !(next > lo.alpha && next < hi.alpha)) next = T(0.5) * (lo.alpha + hi.alpha);
    if (next == p.alpha) break;
    p = line_eval(m, d, gauss, next, ln);
  }
  if (p.cost <= best.cost) best = p;
  return best.cost < p0.cost ? best.alpha : T(0);
}

// The constrained acceleration: qacc, efc_state, efc_force, qfrc_constraint, qacc_warmstart.
template <class T>
BIDEX_HD void fwd_constraint(const Model<T>& m, const World<T>& d, Lanes ln) {
  const int nv = m.s.nv;
  int nact = 0;
  for (int c = ln.id; c < m.s.ncand; c += ln.n) nact += d.efc_active[c];
  nact = ln.sum(nact);
  if (nact == 0) {
    for (int i = ln.id; i < nv; i += ln.n) {
      d.qacc[i] = d.qacc_warmstart[i] = d.qacc_smooth[i];
      d.qfrc_constraint[i] = 0;
    }
    if (ln.id == 0) d.solver_niter[0] = 0;
    ln.sync();
    return;
  }

  // start from the cheaper of the last solution and the unconstrained acceleration
  bool smooth = true;
  if (m.opt.warmstart) {
    for (int i = ln.id; i < nv; i += ln.n) d.qacc[i] = d.qacc_warmstart[i];
    ln.sync();
    mul_m(m, d.qM, d.qacc, d.sol_Ma, ln);
    T cs = 0;
    for (int c = ln.id; c < m.s.ncand; c += ln.n) {
      if (!d.efc_active[c]) continue;
      d.efc_jar[c] = row_dot(m, d, c, d.qacc) - d.efc_aref[c];
      int st;
      T f;
      cs += row_update(m, d, c, row_dot(m, d, c, d.qacc_smooth) - d.efc_aref[c], &st, &f);
    }
    ln.sync();
    const T cost_smooth = ln.sum(cs);
    const T cost_warm =
        update_constraint(m, d, ln, nullptr) + gauss_cost(m, d, d.sol_Ma, d.qacc, ln);
    smooth = cost_warm > cost_smooth;
  }
  if (smooth) {
    for (int i = ln.id; i < nv; i += ln.n) d.qacc[i] = d.qacc_smooth[i];
    ln.sync();
  }

  // initial state, Hessian and direction
  mul_m(m, d.qM, d.qacc, d.sol_Ma, ln);
  for (int c = ln.id; c < m.s.ncand; c += ln.n)
    if (d.efc_active[c]) d.efc_jar[c] = row_dot(m, d, c, d.qacc) - d.efc_aref[c];
  ln.sync();
  T cost = update_constraint(m, d, ln, nullptr) + gauss_cost(m, d, d.sol_Ma, d.qacc, ln);
  hessian(m, d, ln);
  gradient(m, d, ln);

  // Newton iterations
  const T scale = T(1) / (m.opt.meaninertia * T(nv > 1 ? nv : 1));
  int iter = 0;
  while (iter < m.opt.iterations) {
    const T gauss0 = gauss_cost(m, d, d.sol_Ma, d.qacc, ln);
    const T alpha = line_search(m, d, gauss0, ln);
    if (alpha == 0) break;
    for (int i = ln.id; i < nv; i += ln.n) {
      d.qacc[i] += alpha * d.sol_search[i];
      d.sol_Ma[i] += alpha * d.sol_Mv[i];
    }
    for (int c = ln.id; c < m.s.ncand; c += ln.n)
      if (d.efc_active[c]) d.efc_jar[c] += alpha * d.efc_jv[c];
    ln.sync();
    const T oldcost = cost;
    int nchange = 0;
    cost = update_constraint(m, d, ln, &nchange) + gauss_cost(m, d, d.sol_Ma, d.qacc, ln);
    if (nchange) hessian(m, d, ln);
    const T gnorm = gradient(m, d, ln);
    ++iter;
    if (scale * (oldcost - cost) < m.opt.tolerance || scale * gnorm < m.opt.tolerance) break;
  }

  for (int i = ln.id; i < nv; i += ln.n) d.qacc_warmstart[i] = d.qacc[i];
  if (ln.id == 0) d.solver_niter[0] = iter;
  ln.sync();
}

}  // namespace bidex::sim::gpu
