// Small fixed-size math of the GPU engine, on plain arrays, for float and double: quaternions
// (w, x, y, z), 3x3 row-major rotation matrices, and 6D spatial vectors in MuJoCo's (rotation,
// translation) order with inertias as 10 numbers (Ixx Iyy Izz Ixy Ixz Iyz, m*c, m).
// Each function computes what MuJoCo 2.2.2's function of the same purpose computes, so stage
// results agree to rounding.
#pragma once

#include "sim/gpu/hd.h"

namespace bidex::sim::gpu {

template <class T>
BIDEX_HD inline void copy3(T* r, const T* a) {
  r[0] = a[0];
  r[1] = a[1];
  r[2] = a[2];
}

template <class T>
BIDEX_HD inline T dot3(const T* a, const T* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

template <class T>
BIDEX_HD inline void cross3(T* r, const T* a, const T* b) {
  T t0 = a[1] * b[2] - a[2] * b[1];
  T t1 = a[2] * b[0] - a[0] * b[2];
  T t2 = a[0] * b[1] - a[1] * b[0];
  r[0] = t0;
  r[1] = t1;
  r[2] = t2;
}

// Normalises v in place and returns its former length; a near-zero vector becomes (1, 0, 0).
template <class T>
BIDEX_HD inline T normalize3(T* v) {
  T norm = g_sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (norm < T(kMinVal)) {
    v[0] = 1;
    v[1] = v[2] = 0;
  } else {
    T inv = T(1) / norm;
    v[0] *= inv;
    v[1] *= inv;
    v[2] *= inv;
  }
  return norm;
}

// Normalises q in place and returns its former length; a near-zero quaternion becomes identity.
template <class T>
BIDEX_HD inline T normalize4(T* q) {
  T norm = g_sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (norm < T(kMinVal)) {
    q[0] = 1;
    q[1] = q[2] = q[3] = 0;
  } else {
    T inv = T(1) / norm;
    q[0] *= inv;
    q[1] *= inv;
    q[2] *= inv;
    q[3] *= inv;
  }
  return norm;
}

// r = a * b (r may alias a or b)
template <class T>
BIDEX_HD inline void mul_quat(T* r, const T* a, const T* b) {
  T w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  T x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  T y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  T z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
  r[0] = w;
  r[1] = x;
  r[2] = y;
  r[3] = z;
}

// r = q rotating v (r must not alias v)
template <class T>
BIDEX_HD inline void rot_vec_quat(T* r, const T* v, const T* q) {
  if (v[0] == 0 && v[1] == 0 && v[2] == 0) {
    r[0] = r[1] = r[2] = 0;
    return;
  }
  if (q[0] == 1 && q[1] == 0 && q[2] == 0 && q[3] == 0) {
    copy3(r, v);
    return;
  }
  // t = w v + q_xyz x v; r = v + 2 q_xyz x t
  T t0 = q[0] * v[0] + q[2] * v[2] - q[3] * v[1];
  T t1 = q[0] * v[1] + q[3] * v[0] - q[1] * v[2];
  T t2 = q[0] * v[2] + q[1] * v[1] - q[2] * v[0];
  r[0] = v[0] + 2 * (q[2] * t2 - q[3] * t1);
  r[1] = v[1] + 2 * (q[3] * t0 - q[1] * t2);
  r[2] = v[2] + 2 * (q[1] * t1 - q[2] * t0);
}

// rotation of `angle` about the unit `axis`
template <class T>
BIDEX_HD inline void axis_angle_quat(T* q, const T* axis, T angle) {
  if (angle == 0) {
    q[0] = 1;
    q[1] = q[2] = q[3] = 0;
    return;
  }
  T s = g_sin(angle * T(0.5));
  q[0] = g_cos(angle * T(0.5));
  q[1] = axis[0] * s;
  q[2] = axis[1] * s;
  q[3] = axis[2] * s;
}

template <class T>
BIDEX_HD inline void quat_to_mat(T* m, const T* q) {
  if (q[0] == 1 && q[1] == 0 && q[2] == 0 && q[3] == 0) {
    for (int i = 0; i < 9; ++i) m[i] = (i % 4 == 0) ? T(1) : T(0);
    return;
  }
  T q00 = q[0] * q[0], q01 = q[0] * q[1], q02 = q[0] * q[2], q03 = q[0] * q[3];
  T q11 = q[1] * q[1], q12 = q[1] * q[2], q13 = q[1] * q[3];
  T q22 = q[2] * q[2], q23 = q[2] * q[3], q33 = q[3] * q[3];
  m[0] = q00 + q11 - q22 - q33;
  m[4] = q00 - q11 + q22 - q33;
  m[8] = q00 - q11 - q22 + q33;
  m[1] = 2 * (q12 - q03);
  m[2] = 2 * (q13 + q02);
  m[3] = 2 * (q12 + q03);
  m[5] = 2 * (q23 - q01);
  m[6] = 2 * (q13 - q02);
  m[7] = 2 * (q23 + q01);
}

// r = M v and r = M' v for a 3x3 row-major M (r must not alias v)
template <class T>
BIDEX_HD inline void mul_mat_vec3(T* r, const T* m, const T* v) {
  r[0] = m[0] * v[0] + m[1] * v[1] + m[2] * v[2];
  r[1] = m[3] * v[0] + m[4] * v[1] + m[5] * v[2];
  r[2] = m[6] * v[0] + m[7] * v[1] + m[8] * v[2];
}
template <class T>
BIDEX_HD inline void mul_mat_t_vec3(T* r, const T* m, const T* v) {
  r[0] = m[0] * v[0] + m[3] * v[1] + m[6] * v[2];
  r[1] = m[1] * v[0] + m[4] * v[1] + m[7] * v[2];
  r[2] = m[2] * v[0] + m[5] * v[1] + m[8] * v[2];
}

// rotation vector (axis * angle, angle in (-pi, pi]) of the unit quaternion q
template <class T>
BIDEX_HD inline void quat_to_vel(T* r, const T* q) {
  T axis[3] = {q[1], q[2], q[3]};
  T sin_half = normalize3(axis);
  T speed = 2 * g_atan2(sin_half, q[0]);
  if (speed > T(kPi)) speed -= 2 * T(kPi);
  r[0] = axis[0] * speed;
  r[1] = axis[1] * speed;
  r[2] = axis[2] * speed;
}

// rotation vector taking qb to qa: qb * quat(r) = qa
template <class T>
BIDEX_HD inline void sub_quat(T* r, const T* qa, const T* qb) {
  T neg[4] = {qb[0], -qb[1], -qb[2], -qb[3]};
  T dif[4];
  mul_quat(dif, neg, qa);
  quat_to_vel(r, dif);
}

// q <- normalise(q) * rotation(vel * scale), vel in q's local frame
template <class T>
BIDEX_HD inline void quat_integrate(T* q, const T* vel, T scale) {
  T axis[3] = {vel[0], vel[1], vel[2]};
  T angle = scale * normalize3(axis);
  T rot[4];
  axis_angle_quat(rot, axis, angle);
  normalize4(q);
  mul_quat(q, q, rot);
}

// Inertia of a body in the world-aligned frame at offset `dif` from its centre of mass, as the
// 10 numbers of a com-based inertia (rotational part about the reference point, m*dif, m).
template <class T>
BIDEX_HD inline void inert_com(T* r, const T* inert, const T* mat, const T* dif, T mass) {
  // mat diag(inert) mat'
  T t[9] = {mat[0] * inert[0], mat[3] * inert[0], mat[6] * inert[0],
            mat[1] * inert[1], mat[4] * inert[1], mat[7] * inert[1],
            mat[2] * inert[2], mat[5] * inert[2], mat[8] * inert[2]};
  r[0] = mat[0] * t[0] + mat[1] * t[3] + mat[2] * t[6];
  r[1] = mat[3] * t[1] + mat[4] * t[4] + mat[5] * t[7];
  r[2] = mat[6] * t[2] + mat[7] * t[5] + mat[8] * t[8];
  r[3] = mat[0] * t[1] + mat[1] * t[4] + mat[2] * t[7];
  r[4] = mat[0] * t[2] + mat[1] * t[5] + mat[2] * t[8];
  r[5] = mat[3] * t[2] + mat[4] * t[5] + mat[5] * t[8];
  // parallel axis
  r[0] += mass * (dif[1] * dif[1] + dif[2] * dif[2]);
  r[1] += mass * (dif[0] * dif[0] + dif[2] * dif[2]);
  r[2] += mass * (dif[0] * dif[0] + dif[1] * dif[1]);
  r[3] -= mass * dif[0] * dif[1];
  r[4] -= mass * dif[0] * dif[2];
  r[5] -= mass * dif[1] * dif[2];
  r[6] = mass * dif[0];
  r[7] = mass * dif[1];
  r[8] = mass * dif[2];
  r[9] = mass;
}

// r = I v for a com-based inertia I and a motion vector v
template <class T>
BIDEX_HD inline void mul_inert_vec(T* r, const T* i, const T* v) {
  r[0] = i[0] * v[0] + i[3] * v[1] + i[4] * v[2] - i[8] * v[4] + i[7] * v[5];
  r[1] = i[3] * v[0] + i[1] * v[1] + i[5] * v[2] + i[8] * v[3] - i[6] * v[5];
  r[2] = i[4] * v[0] + i[5] * v[1] + i[2] * v[2] - i[7] * v[3] + i[6] * v[4];
  r[3] = i[8] * v[1] - i[7] * v[2] + i[9] * v[3];
  r[4] = i[6] * v[2] - i[8] * v[0] + i[9] * v[4];
  r[5] = i[7] * v[0] - i[6] * v[1] + i[9] * v[5];
}

// motion cross product r = vel x v (r must not alias its inputs)
template <class T>
BIDEX_HD inline void cross_motion(T* r, const T* vel, const T* v) {
  r[0] = -vel[2] * v[1] + vel[1] * v[2];
  r[1] = vel[2] * v[0] - vel[0] * v[2];
  r[2] = -vel[1] * v[0] + vel[0] * v[1];
  r[3] = -vel[2] * v[4] + vel[1] * v[5];
  r[4] = vel[2] * v[3] - vel[0] * v[5];
  r[5] = -vel[1] * v[3] + vel[0] * v[4];
  r[3] += -vel[5] * v[1] + vel[4] * v[2];
  r[4] += vel[5] * v[0] - vel[3] * v[2];
  r[5] += -vel[4] * v[0] + vel[3] * v[1];
}

// force cross product r = vel x* f (r must not alias its inputs)
template <class T>
BIDEX_HD inline void cross_force(T* r, const T* vel, const T* f) {
  r[0] = -vel[2] * f[1] + vel[1] * f[2];
  r[1] = vel[2] * f[0] - vel[0] * f[2];
  r[2] = -vel[1] * f[0] + vel[0] * f[1];
  r[3] = -vel[2] * f[4] + vel[1] * f[5];
  r[4] = vel[2] * f[3] - vel[0] * f[5];
  r[5] = -vel[1] * f[3] + vel[0] * f[4];
  r[0] += -vel[5] * f[4] + vel[4] * f[5];
  r[1] += vel[5] * f[3] - vel[3] * f[5];
  r[2] += -vel[4] * f[3] + vel[3] * f[4];
}

template <class T>
BIDEX_HD inline T dot6(const T* a, const T* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5];
}

}  // namespace bidex::sim::gpu
