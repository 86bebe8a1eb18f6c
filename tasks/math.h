// Small vector and quaternion helpers for per-slot task math. Plain arrays of doubles, no
// MuJoCo types, so the same functions can be compiled for the GPU engine later. Quaternions are
// (w, x, y, z), MuJoCo's order; observations write them as (x, y, z, w) (see tasks/README.md).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>

namespace bidex::tasks::math {

inline double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double norm3(const double* a) { return std::sqrt(dot3(a, a)); }
inline double dist3(const double* a, const double* b) {
  const double d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
  return norm3(d);
}
inline void cross3(double* out, const double* a, const double* b) {
  const double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                       a[0] * b[1] - a[1] * b[0]};
  out[0] = c[0];
  out[1] = c[1];
  out[2] = c[2];
}

// out = a * b (Hamilton product); out may alias a or b.
inline void quat_mul(double* out, const double* a, const double* b) {
  const double w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  const double x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  const double y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  const double z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
  out[0] = w;
  out[1] = x;
  out[2] = y;
  out[3] = z;
}
inline void quat_conj(double* out, const double* q) {
  out[0] = q[0];
  out[1] = -q[1];
  out[2] = -q[2];
  out[3] = -q[3];
}
// out = R(q) v; out may alias v.
inline void quat_rotate(double* out, const double* q, const double* v) {
  // v' = v + 2 w (u x v) + 2 u x (u x v), u = vector part
  const double* u = q + 1;
  double t[3], c[3];
  cross3(t, u, v);
  for (int k = 0; k < 3; ++k) t[k] *= 2;
  cross3(c, u, t);
  for (int k = 0; k < 3; ++k) out[k] = v[k] + q[0] * t[k] + c[k];
}
// The point at `local` in a body frame at (pos, quat), in world coordinates.
inline void frame_point(double* out, const double* pos, const double* quat, const double* local) {
  quat_rotate(out, quat, local);
  for (int k = 0; k < 3; ++k) out[k] += pos[k];
}
inline void quat_axis_angle(double* out, const double* axis, double angle) {
  const double s = std::sin(angle / 2);
  out[0] = std::cos(angle / 2);
  out[1] = axis[0] * s;
  out[2] = axis[1] * s;
  out[3] = axis[2] * s;
}

// The rotation between two orientations: 2 asin(min(|vec(a * conj(b))|, 1)), in [0, pi].
inline double rot_distance(const double* a, const double* b) {
  double bc[4], d[4];
  quat_conj(bc, b);
  quat_mul(d, a, bc);
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

// Uniform in [lo, hi) from 53 random bits (the same on every platform, unlike
// std::uniform_real_distribution).
inline double uniform(std::mt19937_64& rng, double lo, double hi) {
  const double u = static_cast<double>(rng() >> 11) * 0x1.0p-53;
  return lo + (hi - lo) * u;
}

// The original's random orientation: rotation about x by pi r0, then about y by pi r1,
// r ~ U(-1, 1), composed as q_x * q_y.
inline void random_rotation(double* out, std::mt19937_64& rng) {
  const double r0 = uniform(rng, -1, 1), r1 = uniform(rng, -1, 1);
  const double ax[3] = {1, 0, 0}, ay[3] = {0, 1, 0};
  double qx[4], qy[4];
  quat_axis_angle(qx, ax, M_PI * r0);
  quat_axis_angle(qy, ay, M_PI * r1);
  quat_mul(out, qx, qy);
}

}  // namespace bidex::tasks::math
