// Smooth dynamics of one world, stage by stage, each the counterpart of a MuJoCo 2.2.2 function:
//   kinematics        mj_kinematics      body, joint, geom and site poses
//   com_pos           mj_comPos          subtree centres of mass, cinert, cdof
//   tendon            mj_tendon          fixed tendon lengths
//   crb               mj_crb             composite inertias and the mass matrix qM
//   factor_m          mj_factorM         L'DL of qM in MuJoCo's tree layout
//   transmission      mj_transmission    actuator lengths (moments are constant: model)
//   fwd_velocity      mj_fwdVelocity     tendon and actuator velocities, com_vel, passive,
//                                        reference_constraint (constraint.h) and rne
//   fwd_actuation     mj_fwdActuation    actuator forces and qfrc_actuator
//   fwd_acceleration  mj_fwdAcceleration qfrc_smooth (with xfrc_applied) and qacc_smooth
//
// Every function runs on the lanes of one world (Lanes): tree passes go level by level with the
// bodies of a level spread over the lanes, backward passes gather from child lists (no atomics,
// MuJoCo's summation order), per-dof and per-joint work is spread over the lanes. Each function
// assumes its inputs are visible to all lanes and ends with a sync.
#pragma once

#include "sim/gpu/data.h"
#include "sim/gpu/hd.h"
#include "sim/gpu/model.h"
#include "sim/gpu/spatial.h"

namespace bidex::sim::gpu {

// dot product of two 6-vectors in MuJoCo's mju_dot order (four partial sums, then the rest)
template <class T>
BIDEX_HD inline T dot6_mj(const T* a, const T* b) {
  T r0 = a[0] * b[0], r1 = a[1] * b[1], r2 = a[2] * b[2], r3 = a[3] * b[3];
  T r = (r0 + r2) + (r1 + r3);
  r += a[4] * b[4];
  r += a[5] * b[5];
  return r;
}

// res(6) = sum_k dof[k] * v[k] over n dofs (MuJoCo's mju_mulDofVec)
template <class T>
BIDEX_HD inline void mul_dof_vec(T* res, const T* dof, const T* v, int n) {
  for (int c = 0; c < 6; ++c) res[c] = 0;
  for (int k = 0; k < n; ++k)
    if (v[k] != 0)
      for (int c = 0; c < 6; ++c) res[c] += dof[6 * k + c] * v[k];
}

// pose of an object attached to `body` (same frame as the body, as its inertia, or its own)
template <class T>
BIDEX_HD inline void local_to_global(const World<T>& d, T* xpos, T* xmat, const T* pos,
                                     const T* quat, int body, int sameframe) {
  if (sameframe == 1) {
    copy3(xpos, d.xpos + 3 * body);
    for (int k = 0; k < 9; ++k) xmat[k] = d.xmat[9 * body + k];
  } else if (sameframe == 2) {
    copy3(xpos, d.xipos + 3 * body);
    for (int k = 0; k < 9; ++k) xmat[k] = d.ximat[9 * body + k];
  } else {
    mul_mat_vec3(xpos, d.xmat + 9 * body, pos);
    for (int k = 0; k < 3; ++k) xpos[k] += d.xpos[3 * body + k];
    T q[4];
    mul_quat(q, d.xquat + 4 * body, quat);
    quat_to_mat(xmat, q);
  }
}

// Body, joint, inertial-frame and (when `poses`) geom and site poses from qpos; normalises the
// quaternions of qpos in place.
template <class T>
BIDEX_HD void kinematics(const Model<T>& m, const World<T>& d, Lanes ln, bool poses = true) {
  // unit quaternions in qpos
  for (int j = ln.id; j < m.s.njnt; j += ln.n) {
    const int t = m.jnt_type[j];
    if (t == kJointBall) normalize4(d.qpos + m.jnt_qposadr[j]);
    if (t == kJointFree) normalize4(d.qpos + m.jnt_qposadr[j] + 3);
  }
  // the world frame
  if (ln.id == 0) {
    for (int k = 0; k < 3; ++k) d.xpos[k] = d.xipos[k] = 0;
    d.xquat[0] = 1;
    d.xquat[1] = d.xquat[2] = d.xquat[3] = 0;
    for (int k = 0; k < 9; ++k) d.xmat[k] = d.ximat[k] = (k % 4 == 0) ? T(1) : T(0);
  }
  ln.sync();

  // bodies, root to leaves, one tree level at a time
  for (int l = 1; l < m.s.nlevel; ++l) {
    for (int k = m.level_adr[l] + ln.id; k < m.level_adr[l + 1]; k += ln.n) {
      const int b = m.level_body[k];
      T pos[3], quat[4];
      const int jadr = m.body_jntadr[b];
      if (m.body_jntnum[b] == 1 && m.jnt_type[jadr] == kJointFree) {
        // free joint: the pose is the joint's coordinates
        const T* q = d.qpos + m.jnt_qposadr[jadr];
        copy3(pos, q);
        for (int c = 0; c < 4; ++c) quat[c] = q[3 + c];
        copy3(d.xanchor + 3 * jadr, pos);
        d.xaxis[3 * jadr] = d.xaxis[3 * jadr + 1] = 0;
        d.xaxis[3 * jadr + 2] = 1;
      } else {
        // fixed offset from the parent, then each joint in turn
        const int p = m.body_parentid[b];
        T vec[3];
        mul_mat_vec3(vec, d.xmat + 9 * p, m.body_pos + 3 * b);
        for (int c = 0; c < 3; ++c) pos[c] = d.xpos[3 * p + c] + vec[c];
        mul_quat(quat, d.xquat + 4 * p, m.body_quat + 4 * b);
        for (int jj = 0; jj < m.body_jntnum[b]; ++jj) {
          const int j = jadr + jj;
          const int qa = m.jnt_qposadr[j];
          const int type = m.jnt_type[j];
          T xaxis[3], xanchor[3];
          rot_vec_quat(xaxis, m.jnt_axis + 3 * j, quat);
          rot_vec_quat(xanchor, m.jnt_pos + 3 * j, quat);
          for (int c = 0; c < 3; ++c) xanchor[c] += pos[c];
          if (type == kJointSlide) {
            const T dq = d.qpos[qa] - m.qpos0[qa];
            for (int c = 0; c < 3; ++c) pos[c] += xaxis[c] * dq;
          } else {
            T qloc[4];
            if (type == kJointBall) {
              for (int c = 0; c < 4; ++c) qloc[c] = d.qpos[qa + c];
            } else {
              axis_angle_quat(qloc, m.jnt_axis + 3 * j, d.qpos[qa] - m.qpos0[qa]);
            }
            mul_quat(quat, quat, qloc);
            // rotation about the anchor, not the body origin
            T v1[3];
            rot_vec_quat(v1, m.jnt_pos + 3 * j, quat);
            for (int c = 0; c < 3; ++c) pos[c] += (xanchor[c] - pos[c]) - v1[c];
          }
          copy3(d.xanchor + 3 * j, xanchor);
          copy3(d.xaxis + 3 * j, xaxis);
        }
      }
      normalize4(quat);
      for (int c = 0; c < 4; ++c) d.xquat[4 * b + c] = quat[c];
      copy3(d.xpos + 3 * b, pos);
      quat_to_mat(d.xmat + 9 * b, quat);
    }
    ln.sync();
  }

  // inertial frames
  for (int b = 1 + ln.id; b < m.s.nbody; b += ln.n)
    local_to_global(d, d.xipos + 3 * b, d.ximat + 9 * b, m.body_ipos + 3 * b,
                    m.body_iquat + 4 * b, b, m.body_sameframe[b]);
  ln.sync();

  // geoms and sites
  if (poses) {
    for (int g = ln.id; g < m.s.ngeom; g += ln.n)
      local_to_global(d, d.geom_xpos + 3 * g, d.geom_xmat + 9 * g, m.geom_pos + 3 * g,
                      m.geom_quat + 4 * g, m.geom_bodyid[g], m.geom_sameframe[g]);
    for (int i = ln.id; i < m.s.nsite; i += ln.n)
      local_to_global(d, d.site_xpos + 3 * i, d.site_xmat + 9 * i, m.site_pos + 3 * i,
                      m.site_quat + 4 * i, m.site_bodyid[i], m.site_sameframe[i]);
    ln.sync();
  }
}

// Subtree centres of mass, com-based inertias and motion axes.
template <class T>
BIDEX_HD void com_pos(const Model<T>& m, const World<T>& d, Lanes ln) {
  // mass-weighted subtree sums, leaves first: children (highest id first), then the body
  for (int l = m.s.nlevel - 1; l >= 0; --l) {
    for (int k = m.level_adr[l] + ln.id; k < m.level_adr[l + 1]; k += ln.n) {
      const int b = m.level_body[k];
      T acc[3] = {0, 0, 0};
      for (int c = m.child_adr[b]; c < m.child_adr[b + 1]; ++c)
        for (int i = 0; i < 3; ++i) acc[i] += d.subtree_com[3 * m.child_body[c] + i];
      for (int i = 0; i < 3; ++i) acc[i] += d.xipos[3 * b + i] * m.body_mass[b];
      copy3(d.subtree_com + 3 * b, acc);
    }
    ln.sync();
  }
  // divide by the subtree masses
  for (int b = ln.id; b < m.s.nbody; b += ln.n) {
    const T mass = m.body_subtreemass[b];
    if (mass < T(kMinVal)) {
      copy3(d.subtree_com + 3 * b, d.xipos + 3 * b);
    } else {
      const T inv = T(1) / g_max(T(kMinVal), mass);
      for (int i = 0; i < 3; ++i) d.subtree_com[3 * b + i] *= inv;
    }
  }
  ln.sync();

  // inertias about the tree's centre of mass, world-aligned
  for (int b = ln.id; b < m.s.nbody; b += ln.n) {
    if (b == 0) {
      for (int i = 0; i < 10; ++i) d.cinert[i] = 0;
      continue;
    }
    T off[3];
    const T* com = d.subtree_com + 3 * m.body_rootid[b];
    for (int i = 0; i < 3; ++i) off[i] = d.xipos[3 * b + i] - com[i];
    inert_com(d.cinert + 10 * b, m.body_inertia + 3 * b, d.ximat + 9 * b, off, m.body_mass[b]);
  }

  // motion axes of the dofs
  for (int j = ln.id; j < m.s.njnt; j += ln.n) {
    T* cdof = d.cdof + 6 * m.jnt_dofadr[j];
    const int b = m.jnt_bodyid[j];
    T off[3];
    const T* com = d.subtree_com + 3 * m.body_rootid[b];
    for (int i = 0; i < 3; ++i) off[i] = com[i] - d.xanchor[3 * j + i];
    const int type = m.jnt_type[j];
    if (type == kJointFree || type == kJointBall) {
      int k0 = 0;
      if (type == kJointFree) {
        // translations along the world axes
        for (int i = 0; i < 18; ++i) cdof[i] = 0;
        for (int i = 0; i < 3; ++i) cdof[3 + 7 * i] = 1;
        k0 = 3;
      }
      // rotations about the body's axes
      for (int i = 0; i < 3; ++i) {
        T* r = cdof + 6 * (k0 + i);
        T axis[3] = {d.xmat[9 * b + i], d.xmat[9 * b + i + 3], d.xmat[9 * b + i + 6]};
        copy3(r, axis);
        cross3(r + 3, axis, off);
      }
    } else if (type == kJointSlide) {
      cdof[0] = cdof[1] = cdof[2] = 0;
      copy3(cdof + 3, d.xaxis + 3 * j);
    } else {
      copy3(cdof, d.xaxis + 3 * j);
      cross3(cdof + 3, d.xaxis + 3 * j, off);
    }
  }
  ln.sync();
}

// Fixed tendon lengths.
template <class T>
BIDEX_HD void tendon(const Model<T>& m, const World<T>& d, Lanes ln) {
  for (int t = ln.id; t < m.s.ntendon; t += ln.n) {
    T len = 0;
    for (int k = m.ten_adr[t]; k < m.ten_adr[t + 1]; ++k)
      len += m.ten_coef[k] * d.qpos[m.ten_qpos[k]];
    d.ten_length[t] = len;
  }
  ln.sync();
}

// Composite rigid-body inertias and the joint-space mass matrix with armature.
template <class T>
BIDEX_HD void crb(const Model<T>& m, const World<T>& d, Lanes ln) {
  // crb = cinert + children's crb, leaves first (children of the world do not add to it)
  for (int l = m.s.nlevel - 1; l >= 0; --l) {
    for (int k = m.level_adr[l] + ln.id; k < m.level_adr[l + 1]; k += ln.n) {
      const int b = m.level_body[k];
      T acc[10];
      for (int i = 0; i < 10; ++i) acc[i] = d.cinert[10 * b + i];
      if (b > 0)
        for (int c = m.child_adr[b]; c < m.child_adr[b + 1]; ++c)
          for (int i = 0; i < 10; ++i) acc[i] += d.crb[10 * m.child_body[c] + i];
      for (int i = 0; i < 10; ++i) d.crb[10 * b + i] = acc[i];
    }
    ln.sync();
  }
  // one row of qM per dof: M(i, j) = cdof_j . (crb_body(i) cdof_i) over i's ancestors j
  for (int i = ln.id; i < m.s.nv; i += ln.n) {
    int e = m.dof_Madr[i];
    const int end = m.dof_Madr[i + 1];
    if (m.dof_simplenum[i]) {
      d.qM[e] = m.dof_M0[i];
      for (++e; e < end; ++e) d.qM[e] = 0;
      continue;
    }
    T tmp[6];
    mul_inert_vec(tmp, d.crb + 10 * m.dof_bodyid[i], d.cdof + 6 * i);
    d.qM[e] = m.dof_armature[i] + dot6_mj(d.cdof + 6 * i, tmp);
    for (++e; e < end; ++e) d.qM[e] = dot6_mj(d.cdof + 6 * m.M_col[e], tmp);
  }
  ln.sync();
}

// In-place L'DL factorisation in MuJoCo's tree layout (mj_factorI): dst = factor of src (src
// may equal dst), diaginv = 1 / diag(D). Pivots below mjMINVAL are raised to it and reported.
// Each tree eliminates its dofs from the last to the first, as MuJoCo does; different trees
// share no rows, so they advance together (one dof of each per step), and the ancestor rows of
// an eliminated dof are updated on separate lanes.
template <class T>
BIDEX_HD bool factor_ld(const Model<T>& m, const T* src, T* dst, T* diaginv, Lanes ln) {
  if (src != dst) {
    for (int e = ln.id; e < m.s.nM; e += ln.n) dst[e] = src[e];
    ln.sync();
  }
  bool floored = false;
  for (int step = 0; step < m.s.maxtreedofs; ++step) {
    // ancestor rows: M(i, :) -= M(k, :) M(k, i) / M(k, k)
    for (int t = 0; t < m.s.ntree; ++t) {
      const int k = m.tree_dofadr[t + 1] - 1 - step;
      if (k < m.tree_dofadr[t]) continue;
      const int adr = m.dof_Madr[k];
      const int nanc = m.dof_Madr[k + 1] - adr - 1;
      T dkk = dst[adr];
      if (dkk < T(kMinVal)) {
        dkk = T(kMinVal);
        floored = true;
      }
      for (int p = ln.id; p < nanc; p += ln.n) {
        const T tmp = dst[adr + 1 + p] / dkk;
        const int i = m.M_col[adr + 1 + p];
        const int iadr = m.dof_Madr[i];
        const int cnt = m.dof_Madr[i + 1] - iadr;
        for (int c = 0; c < cnt; ++c) dst[iadr + c] -= dst[adr + 1 + p + c] * tmp;
      }
    }
    ln.sync();
    // rows k become L(k, :)
    for (int t = 0; t < m.s.ntree; ++t) {
      const int k = m.tree_dofadr[t + 1] - 1 - step;
      if (k < m.tree_dofadr[t]) continue;
      const int adr = m.dof_Madr[k];
      const int nanc = m.dof_Madr[k + 1] - adr - 1;
      const T dkk = g_max(dst[adr], T(kMinVal));
      for (int p = ln.id; p < nanc; p += ln.n) dst[adr + 1 + p] /= dkk;
    }
    ln.sync();
    for (int t = ln.id; t < m.s.ntree; t += ln.n) {
      const int k = m.tree_dofadr[t + 1] - 1 - step;
      if (k >= m.tree_dofadr[t] && dst[m.dof_Madr[k]] < T(kMinVal)) dst[m.dof_Madr[k]] = T(kMinVal);
    }
  }
  ln.sync();
  for (int i = ln.id; i < m.s.nv; i += ln.n) diaginv[i] = T(1) / dst[m.dof_Madr[i]];
  ln.sync();
  return floored;
}

// x = (L'DL)^-1 y for a factor from factor_ld (x may equal y). The dofs of one depth of the
// dof tree are independent in both triangular solves, so each pass goes depth by depth with the
// dofs of a depth on separate lanes (MuJoCo's order of operations per dof is kept: a dof's
// column is gathered last row first, its row in ancestor order).
template <class T>
BIDEX_HD void solve_ld(const Model<T>& m, const T* L, const T* diaginv, T* x, const T* y,
                       Lanes ln) {
  if (x != y) {
    for (int i = ln.id; i < m.s.nv; i += ln.n) x[i] = y[i];
    ln.sync();
  }
  // x <- L'^-1 x, deepest dofs first: x(j) -= L(i, j) x(i) over the descendants i of j
  for (int l = m.s.ndlevel - 1; l >= 0; --l) {
    for (int k = m.dlevel_adr[l] + ln.id; k < m.dlevel_adr[l + 1]; k += ln.n) {
      const int j = m.dlevel_dof[k];
      T t = x[j];
      for (int c = m.M_coladr[j]; c < m.M_coladr[j + 1]; ++c) {
        const int e = m.M_colent[c];
        const T xi = x[m.M_row[e]];
        if (xi != 0) t -= L[e] * xi;
      }
      x[j] = t;
    }
    ln.sync();
  }
  // x <- D^-1 x
  for (int i = ln.id; i < m.s.nv; i += ln.n) x[i] *= diaginv[i];
  ln.sync();
  // x <- L^-1 x, roots first: x(i) -= L(i, j) x(j) over the ancestors j of i
  for (int l = 0; l < m.s.ndlevel; ++l) {
    for (int k = m.dlevel_adr[l] + ln.id; k < m.dlevel_adr[l + 1]; k += ln.n) {
      const int i = m.dlevel_dof[k];
      T t = x[i];
      for (int e = m.dof_Madr[i] + 1; e < m.dof_Madr[i + 1]; ++e) t -= L[e] * x[m.M_col[e]];
      x[i] = t;
    }
    ln.sync();
  }
}

// res = M x for M in the tree layout (res must not alias x).
template <class T>
BIDEX_HD void mul_m(const Model<T>& m, const T* M, const T* x, T* res, Lanes ln) {
  for (int i = ln.id; i < m.s.nv; i += ln.n) {
    const int adr = m.dof_Madr[i];
    // row i: the diagonal and the ancestors
    T r = M[adr] * x[i];
    for (int e = adr + 1; e < m.dof_Madr[i + 1]; ++e) r += M[e] * x[m.M_col[e]];
    // column i below the diagonal: the descendants
    for (int c = m.M_coladr[i]; c < m.M_coladr[i + 1]; ++c) {
      const int e = m.M_colent[c];
      r += M[e] * x[m.M_row[e]];
    }
    res[i] = r;
  }
  ln.sync();
}

template <class T>
BIDEX_HD void factor_m(const Model<T>& m, const World<T>& d, Lanes ln) {
  if (factor_ld(m, d.qM, d.qLD, d.qLDiagInv, ln) && ln.id == 0) d.fault[0] |= kGpuFaultInertia;
}

// Actuator lengths (joint: gear * qpos; tendon: gear * length).
template <class T>
BIDEX_HD void transmission(const Model<T>& m, const World<T>& d, Lanes ln) {
  for (int a = ln.id; a < m.s.nu; a += ln.n) {
    const T q = m.act_trn[a] == 0 ? d.qpos[m.act_obj[a]] : d.ten_length[m.act_obj[a]];
    d.actuator_length[a] = q * m.actuator_gear[a];
  }
  ln.sync();
}

// Body velocities (cvel) and the time derivatives of the motion axes (cdof_dot), root first.
template <class T>
BIDEX_HD void com_vel(const Model<T>& m, const World<T>& d, Lanes ln) {
  if (ln.id == 0)
    for (int c = 0; c < 6; ++c) d.cvel[c] = 0;
  ln.sync();
  for (int l = 1; l < m.s.nlevel; ++l) {
    for (int k = m.level_adr[l] + ln.id; k < m.level_adr[l + 1]; k += ln.n) {
      const int b = m.level_body[k];
      const int bda = m.body_dofadr[b];
      T cvel[6], tmp[6];
      for (int c = 0; c < 6; ++c) cvel[c] = d.cvel[6 * m.body_parentid[b] + c];
      for (int j = 0; j < m.body_dofnum[b]; ++j) {
        const int type = m.jnt_type[m.dof_jntid[bda + j]];
        if (type == kJointFree || type == kJointBall) {
          if (type == kJointFree) {
            // translations: no axis change; velocity first
            for (int c = 0; c < 18; ++c) d.cdof_dot[6 * (bda + j) + c] = 0;
            mul_dof_vec(tmp, d.cdof + 6 * (bda + j), d.qvel + bda + j, 3);
            for (int c = 0; c < 6; ++c) cvel[c] += tmp[c];
            j += 3;
          }
          // the three rotations use the velocity before their own contribution
          for (int r = 0; r < 3; ++r)
            cross_motion(d.cdof_dot + 6 * (bda + j + r), cvel, d.cdof + 6 * (bda + j + r));
          mul_dof_vec(tmp, d.cdof + 6 * (bda + j), d.qvel + bda + j, 3);
          for (int c = 0; c < 6; ++c) cvel[c] += tmp[c];
          j += 2;
        } else {
          cross_motion(d.cdof_dot + 6 * (bda + j), cvel, d.cdof + 6 * (bda + j));
          mul_dof_vec(tmp, d.cdof + 6 * (bda + j), d.qvel + bda + j, 1);
          for (int c = 0; c < 6; ++c) cvel[c] += tmp[c];
        }
      }
      for (int c = 0; c < 6; ++c) d.cvel[6 * b + c] = cvel[c];
    }
    ln.sync();
  }
}

// Joint springs and dampers, then fixed-tendon springs and dampers.
template <class T>
BIDEX_HD void passive(const Model<T>& m, const World<T>& d, Lanes ln) {
  const bool off = (m.opt.disableflags & kDisablePassive) != 0;
  // one joint's dofs per lane: spring, then damper
  for (int j = ln.id; j < m.s.njnt; j += ln.n) {
    int pa = m.jnt_qposadr[j], da = m.jnt_dofadr[j];
    const int type = m.jnt_type[j];
    const int ndof = type == kJointFree ? 6 : (type == kJointBall ? 3 : 1);
    T f[6] = {0, 0, 0, 0, 0, 0};
    if (!off) {
      const T k = m.jnt_stiffness[j];
      int r = 0;
      if (type == kJointFree) {
        for (int c = 0; c < 3; ++c) f[c] = -(k * (d.qpos[pa + c] - m.qpos_spring[pa + c]));
        r = 3;
        pa += 3;
      }
      if (type == kJointFree || type == kJointBall) {
        T dif[3];
        sub_quat(dif, d.qpos + pa, m.qpos_spring + pa);
        for (int c = 0; c < 3; ++c) f[r + c] = -(k * dif[c]);
      } else {
        f[0] = -(k * (d.qpos[pa] - m.qpos_spring[pa]));
      }
      for (int c = 0; c < ndof; ++c) f[c] -= m.dof_damping[da + c] * d.qvel[da + c];
    }
    for (int c = 0; c < ndof; ++c) d.qfrc_passive[da + c] = f[c];
  }
  ln.sync();
  // tendons add along their Jacobians (one lane, in tendon order)
  if (!off && m.s.ntendon > 0) {
    if (ln.id == 0)
      for (int t = 0; t < m.s.ntendon; ++t) {
        const T frc = -m.tendon_stiffness[t] * (d.ten_length[t] - m.tendon_lengthspring[t]) -
                      m.tendon_damping[t] * d.ten_velocity[t];
        for (int k = m.ten_adr[t]; k < m.ten_adr[t + 1]; ++k)
          d.qfrc_passive[m.ten_dof[k]] += m.ten_coef[k] * frc;
      }
    ln.sync();
  }
}

// Bias forces: M(q) qacc + C(q, qvel) with qacc = 0 (Coriolis, centrifugal, gravity).
template <class T>
BIDEX_HD void rne(const Model<T>& m, const World<T>& d, Lanes ln) {
  if (ln.id == 0) {
    for (int c = 0; c < 6; ++c) d.rne_cacc[c] = d.rne_cfrc[c] = 0;
    if (!(m.opt.disableflags & kDisableGravity))
      for (int c = 0; c < 3; ++c) d.rne_cacc[3 + c] = -m.opt.gravity[c];
  }
  ln.sync();
  // accelerations root first, and each body's own force
  for (int l = 1; l < m.s.nlevel; ++l) {
    for (int k = m.level_adr[l] + ln.id; k < m.level_adr[l + 1]; k += ln.n) {
      const int b = m.level_body[k];
      const int bda = m.body_dofadr[b];
      T tmp[6], tmp1[6];
      T* cacc = d.rne_cacc + 6 * b;
      mul_dof_vec(tmp, d.cdof_dot + 6 * bda, d.qvel + bda, m.body_dofnum[b]);
      for (int c = 0; c < 6; ++c) cacc[c] = d.rne_cacc[6 * m.body_parentid[b] + c] + tmp[c];
      T* f = d.rne_cfrc + 6 * b;
      mul_inert_vec(f, d.cinert + 10 * b, cacc);
      mul_inert_vec(tmp, d.cinert + 10 * b, d.cvel + 6 * b);
      cross_force(tmp1, d.cvel + 6 * b, tmp);
      for (int c = 0; c < 6; ++c) f[c] += tmp1[c];
    }
    ln.sync();
  }
  // subtree forces, leaves first (children of the world do not add to it)
  for (int l = m.s.nlevel - 1; l >= 1; --l) {
    for (int k = m.level_adr[l] + ln.id; k < m.level_adr[l + 1]; k += ln.n) {
      const int b = m.level_body[k];
      T* f = d.rne_cfrc + 6 * b;
      for (int c = m.child_adr[b]; c < m.child_adr[b + 1]; ++c)
        for (int i = 0; i < 6; ++i) f[i] += d.rne_cfrc[6 * m.child_body[c] + i];
    }
    ln.sync();
  }
  // project on the dofs
  for (int i = ln.id; i < m.s.nv; i += ln.n)
    d.qfrc_bias[i] = dot6_mj(d.cdof + 6 * i, d.rne_cfrc + 6 * m.dof_bodyid[i]);
  ln.sync();
}

// Actuator forces: clamped controls, gain and bias, force limits, then joint-space forces.
template <class T>
BIDEX_HD void fwd_actuation(const Model<T>& m, const World<T>& d, Lanes ln) {
  const bool off = m.s.nu == 0 || (m.opt.disableflags & kDisableActuation);
  if (!off) {
    // clamped controls; a non-finite one zeroes them all (and is reported)
    int bad = 0;
    for (int a = ln.id; a < m.s.nu; a += ln.n) {
      T c = d.ctrl[a];
      if (!(m.opt.disableflags & kDisableClampCtrl) && m.actuator_ctrllimited[a])
        c = g_clip(c, m.actuator_ctrlrange[2 * a], m.actuator_ctrlrange[2 * a + 1]);
      if (!g_finite(c)) bad = 1;
    }
    bad = ln.max(bad);
    if (bad && ln.id == 0) d.fault[0] |= kGpuFaultBadCtrl;
    for (int a = ln.id; a < m.s.nu; a += ln.n) {
      T c = 0;
      if (!bad) {
        c = d.ctrl[a];
        if (!(m.opt.disableflags & kDisableClampCtrl) && m.actuator_ctrllimited[a])
          c = g_clip(c, m.actuator_ctrlrange[2 * a], m.actuator_ctrlrange[2 * a + 1]);
      }
      const T* g = m.actuator_gainprm + 3 * a;
      const T* p = m.actuator_biasprm + 3 * a;
      const T len = d.actuator_length[a], vel = d.actuator_velocity[a];
      const T gain = m.actuator_gaintype[a] == kGainFixed ? g[0] : g[0] + g[1] * len + g[2] * vel;
      const T bias = m.actuator_biastype[a] == kBiasNone ? T(0) : p[0] + p[1] * len + p[2] * vel;
      T force = gain * c;
      force += bias;
      if (m.actuator_forcelimited[a])
        force = g_clip(force, m.actuator_forcerange[2 * a], m.actuator_forcerange[2 * a + 1]);
      d.actuator_force[a] = force;
    }
  } else {
    for (int a = ln.id; a < m.s.nu; a += ln.n) d.actuator_force[a] = 0;
  }
  ln.sync();
  // qfrc_actuator = moment' force, gathered per dof in actuator order
  for (int i = ln.id; i < m.s.nv; i += ln.n) {
    T r = 0;
    if (!off)
      for (int e = m.dof_actadr[i]; e < m.dof_actadr[i + 1]; ++e) {
        const int k = m.dof_actent[e];
        const T f = d.actuator_force[m.act_of[k]];
        if (f != 0) r += m.act_moment[k] * f;
      }
    d.qfrc_actuator[i] = r;
  }
  ln.sync();
}

// Applied body forces (xfrc_applied, at the centre of mass) mapped to joint forces and added to
// qfrc: for each dof, the bodies it moves in increasing order, through the point Jacobian.
template <class T>
BIDEX_HD void xfrc_accumulate(const Model<T>& m, const World<T>& d, T* qfrc, Lanes ln) {
  for (int i = ln.id; i < m.s.nv; i += ln.n) {
    const T* cdof = d.cdof + 6 * i;
    T r = qfrc[i];
    for (int k = m.dof_subtreeadr[i]; k < m.dof_subtreeadr[i + 1]; ++k) {
      const int b = m.dof_subtreebody[k];
      const T* f = d.xfrc_applied + 6 * b;
      if (f[0] == 0 && f[1] == 0 && f[2] == 0 && f[3] == 0 && f[4] == 0 && f[5] == 0) continue;
      // translational Jacobian column at xipos: lin + ang x (p - com of the tree)
      T off[3], jp[3];
      const T* com = d.subtree_com + 3 * m.body_rootid[b];
      for (int c = 0; c < 3; ++c) off[c] = d.xipos[3 * b + c] - com[c];
      cross3(jp, cdof, off);
      for (int c = 0; c < 3; ++c) jp[c] += cdof[3 + c];
      const T fp = jp[0] * f[0] + jp[1] * f[1] + jp[2] * f[2];
      const T fr = cdof[0] * f[3] + cdof[1] * f[4] + cdof[2] * f[5];
      r += fp + fr;
    }
    qfrc[i] = r;
  }
  ln.sync();
}

// Sum of the non-constraint forces and the unconstrained acceleration.
template <class T>
BIDEX_HD void fwd_acceleration(const Model<T>& m, const World<T>& d, Lanes ln) {
  for (int i = ln.id; i < m.s.nv; i += ln.n) {
    T f = d.qfrc_passive[i] - d.qfrc_bias[i];
    f += d.qfrc_applied[i];
    f += d.qfrc_actuator[i];
    d.qfrc_smooth[i] = f;
  }
  ln.sync();
  xfrc_accumulate(m, d, d.qfrc_smooth, ln);
  solve_ld(m, d.qLD, d.qLDiagInv, d.qacc_smooth, d.qfrc_smooth, ln);
}

}  // namespace bidex::sim::gpu
