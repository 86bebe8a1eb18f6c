// Vector and quaternion helpers for per-slot task math: plain arrays of doubles, no MuJoCo
// types. The basic operations are marked for host and device (core/hd.h). Quaternions are (w, x, y, z), MuJoCo's order; observations write them as
// (x, y, z, w) (put_quat_xyzw, tasks/README.md).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>

#include "sim/batch.h"
#include "core/hd.h"

namespace bidex::tasks::math {

using sim::uniform;

BIDEX_HD inline double dot3(const double* a, const double* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
// out = a x b; out may alias a or b
BIDEX_HD inline void cross3(double* out, const double* a, const double* b) {
  const double t0 = a[1] * b[2] - a[2] * b[1];
  const double t1 = a[2] * b[0] - a[0] * b[2];
  const double t2 = a[0] * b[1] - a[1] * b[0];
  out[0] = t0;
  out[1] = t1;
  out[2] = t2;
}
// out = a * b (Hamilton product); out may alias a or b
BIDEX_HD inline void mul_quat(double* out, const double* a, const double* b) {
  const double w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  const double x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  const double y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  const double z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
  out[0] = w;
  out[1] = x;
  out[2] = y;
  out[3] = z;
}
// out = q v q*, the vector v rotated by the unit quaternion q; out must not alias v
BIDEX_HD inline void rot_vec_quat(double* out, const double* v, const double* q) {
  // t = w v + q_xyz x v; out = v + 2 q_xyz x t
  const double t0 = q[0] * v[0] + q[2] * v[2] - q[3] * v[1];
  const double t1 = q[0] * v[1] + q[3] * v[0] - q[1] * v[2];
  const double t2 = q[0] * v[2] + q[1] * v[1] - q[2] * v[0];
  out[0] = v[0] + 2 * (q[2] * t2 - q[3] * t1);
  out[1] = v[1] + 2 * (q[3] * t0 - q[1] * t2);
  out[2] = v[2] + 2 * (q[1] * t1 - q[2] * t0);
}
// The rotation by `angle` (rad) about the unit vector `axis`.
BIDEX_HD inline void axis_angle_quat(double* q, const double* axis, double angle) {
  const double s = sin(angle * 0.5);
  q[0] = cos(angle * 0.5);
  q[1] = axis[0] * s;
  q[2] = axis[1] * s;
  q[3] = axis[2] * s;
}

inline double norm3(const double* a) { return std::sqrt(dot3(a, a)); }
inline double dist3(const double* a, const double* b) {
  const double d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
  return norm3(d);
}
inline void quat_conj(double* out, const double* q) {
  out[0] = q[0];
  out[1] = -q[1];
  out[2] = -q[2];
  out[3] = -q[3];
}
// The point at `local` in a body frame at (pos, quat), in world coordinates.
inline void frame_point(double* out, const double* pos, const double* quat, const double* local) {
  rot_vec_quat(out, local, quat);
  for (int k = 0; k < 3; ++k) out[k] += pos[k];
}

// An observation's quaternion: (w, x, y, z) written as (x, y, z, w), the original's order.
inline void put_quat_xyzw(float* out, const double* q) {
  out[0] = static_cast<float>(q[1]);
  out[1] = static_cast<float>(q[2]);
  out[2] = static_cast<float>(q[3]);
  out[3] = static_cast<float>(q[0]);
}

// The rotation between two orientations: 2 asin(min(|vec(a * conj(b))|, 1)), in [0, pi].
inline double rot_distance(const double* a, const double* b) {
  double bc[4], d[4];
  quat_conj(bc, b);
  mul_quat(d, a, bc);
  return 2.0 * std::asin(std::min(norm3(d + 1), 1.0));
}

// Roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll), each wrapped to [0, 2 pi).
inline void euler_xyz(double* out, const double* q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double roll = std::atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
  const double sp = 2 * (w * y - z * x);
  const double pitch = std::abs(sp) >= 1 ? std::copysign(M_PI / 2, sp) : std::asin(sp);
  const double yaw = std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
  const double r[3] = {roll, pitch, yaw};
  for (int k = 0; k < 3; ++k) {
    double a = std::fmod(r[k], 2 * M_PI);
    if (a < 0) a += 2 * M_PI;
    out[k] = a >= 2 * M_PI ? a - 2 * M_PI : a;  // a tiny negative angle rounds up to 2 pi
  }
}

// The original's random orientation: rotation about x by pi r0, then about y by pi r1,
// r ~ U(-1, 1), composed as q_x * q_y.
inline void random_rotation(double* out, std::mt19937_64& rng) {
  const double r0 = uniform(rng, -1, 1), r1 = uniform(rng, -1, 1);
  const double ax[3] = {1, 0, 0}, ay[3] = {0, 1, 0};
  double qx[4], qy[4];
  axis_angle_quat(qx, ax, M_PI * r0);
  axis_angle_quat(qy, ay, M_PI * r1);
  mul_quat(out, qx, qy);
}

}  // namespace bidex::tasks::math
