// Vector and quaternion helpers for per-slot task math: plain arrays, no MuJoCo types, templates
// over the scalar (double on the CPU, float or double in device code) and marked for host and
// device (core/hd.h). Quaternions are (w, x, y, z), MuJoCo's order; observations write them as
// (x, y, z, w) (put_quat_xyzw, tasks/README.md). Stage bodies call the scalar functions below
// (math::sqrt, math::exp, ...), which pick the float or double function on either side.
#pragma once

#include <cmath>
#include <cstdint>

#include "core/hd.h"
#include "core/rng.h"

namespace bidex::tasks::math {

constexpr double kPi = 3.14159265358979323846;

// ---- scalars ------------------------------------------------------------------------------

BIDEX_HD inline double sqrt(double x) { return ::sqrt(x); }
BIDEX_HD inline float sqrt(float x) { return ::sqrtf(x); }
BIDEX_HD inline double exp(double x) { return ::exp(x); }
BIDEX_HD inline float exp(float x) { return ::expf(x); }
BIDEX_HD inline double sin(double x) { return ::sin(x); }
BIDEX_HD inline float sin(float x) { return ::sinf(x); }
BIDEX_HD inline double cos(double x) { return ::cos(x); }
BIDEX_HD inline float cos(float x) { return ::cosf(x); }
BIDEX_HD inline double asin(double x) { return ::asin(x); }
BIDEX_HD inline float asin(float x) { return ::asinf(x); }
BIDEX_HD inline double acos(double x) { return ::acos(x); }
BIDEX_HD inline float acos(float x) { return ::acosf(x); }
BIDEX_HD inline double atan2(double y, double x) { return ::atan2(y, x); }
BIDEX_HD inline float atan2(float y, float x) { return ::atan2f(y, x); }
BIDEX_HD inline double fmod(double x, double y) { return ::fmod(x, y); }
BIDEX_HD inline float fmod(float x, float y) { return ::fmodf(x, y); }
BIDEX_HD inline double abs(double x) { return ::fabs(x); }
BIDEX_HD inline float abs(float x) { return ::fabsf(x); }
BIDEX_HD inline double copysign(double x, double y) { return ::copysign(x, y); }
BIDEX_HD inline float copysign(float x, float y) { return ::copysignf(x, y); }
// std::min, std::max and std::clamp's results (a NaN `v` passes through clamp)
template <class T>
BIDEX_HD inline T min(T a, T b) {
  return b < a ? b : a;
}
template <class T>
BIDEX_HD inline T max(T a, T b) {
  return a < b ? b : a;
}
template <class T>
BIDEX_HD inline T clamp(T v, T lo, T hi) {
  return v < lo ? lo : hi < v ? hi : v;
}
// x - x is 0 for a finite x and NaN for an infinite or NaN one (no library call on either side)
template <class T>
BIDEX_HD inline bool isfinite(T x) {
  return x - x == T(0);
}
template <class T>
BIDEX_HD inline bool all_finite(const T* x, int n) {
  for (int i = 0; i < n; ++i)
    if (!isfinite(x[i])) return false;
  return true;
}

// An observation row clipped to [-c, c] in place, a non-finite value set to 0; false when a value
// was not finite (the task stages then fault the world: tasks/README.md, "Faults").
BIDEX_HD inline bool clip_finite(float* o, int n, float c) {
  bool finite = true;
  for (int i = 0; i < n; ++i) {
    if (!isfinite(o[i])) {
      finite = false;
      o[i] = 0.0f;
    } else {
      o[i] = clamp(o[i], -c, c);
    }
  }
  return finite;
}

// ---- vectors and quaternions --------------------------------------------------------------

template <class T>
BIDEX_HD inline T dot3(const T* a, const T* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
// out = a x b; out may alias a or b
template <class T>
BIDEX_HD inline void cross3(T* out, const T* a, const T* b) {
  const T t0 = a[1] * b[2] - a[2] * b[1];
  const T t1 = a[2] * b[0] - a[0] * b[2];
  const T t2 = a[0] * b[1] - a[1] * b[0];
  out[0] = t0;
  out[1] = t1;
  out[2] = t2;
}
// out = a * b (Hamilton product); out may alias a or b
template <class T>
BIDEX_HD inline void mul_quat(T* out, const T* a, const T* b) {
  const T w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  const T x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  const T y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  const T z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
  out[0] = w;
  out[1] = x;
  out[2] = y;
  out[3] = z;
}
// out = q v q*, the vector v rotated by the unit quaternion q; out must not alias v
template <class T>
BIDEX_HD inline void rot_vec_quat(T* out, const T* v, const T* q) {
  // t = w v + q_xyz x v; out = v + 2 q_xyz x t
  const T t0 = q[0] * v[0] + q[2] * v[2] - q[3] * v[1];
  const T t1 = q[0] * v[1] + q[3] * v[0] - q[1] * v[2];
  const T t2 = q[0] * v[2] + q[1] * v[1] - q[2] * v[0];
  out[0] = v[0] + 2 * (q[2] * t2 - q[3] * t1);
  out[1] = v[1] + 2 * (q[3] * t0 - q[1] * t2);
  out[2] = v[2] + 2 * (q[1] * t1 - q[2] * t0);
}
// The rotation by `angle` (rad) about the unit vector `axis`.
template <class T>
BIDEX_HD inline void axis_angle_quat(T* q, const T* axis, T angle) {
  const T s = sin(angle * T(0.5));
  q[0] = cos(angle * T(0.5));
  q[1] = axis[0] * s;
  q[2] = axis[1] * s;
  q[3] = axis[2] * s;
}

template <class T>
BIDEX_HD inline T norm3(const T* a) {
  return sqrt(dot3(a, a));
}
template <class T>
BIDEX_HD inline T dist3(const T* a, const T* b) {
  const T d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
  return norm3(d);
}
template <class T>
BIDEX_HD inline void quat_conj(T* out, const T* q) {
  out[0] = q[0];
  out[1] = -q[1];
  out[2] = -q[2];
  out[3] = -q[3];
}
// The point at `local` in a body frame at (pos, quat), in world coordinates.
template <class T>
BIDEX_HD inline void frame_point(T* out, const T* pos, const T* quat, const T* local) {
  rot_vec_quat(out, local, quat);
  for (int k = 0; k < 3; ++k) out[k] += pos[k];
}

// An observation's vector: 3 values as floats.
template <class T>
BIDEX_HD inline void put_vec3(float* out, const T* v) {
  for (int k = 0; k < 3; ++k) out[k] = static_cast<float>(v[k]);
}

// An observation's quaternion: (w, x, y, z) written as (x, y, z, w), the original's order.
template <class T>
BIDEX_HD inline void put_quat_xyzw(float* out, const T* q) {
  out[0] = static_cast<float>(q[1]);
  out[1] = static_cast<float>(q[2]);
  out[2] = static_cast<float>(q[3]);
  out[3] = static_cast<float>(q[0]);
}

// The rotation between two orientations: 2 asin(min(|vec(a * conj(b))|, 1)), in [0, pi].
template <class T>
BIDEX_HD inline T rot_distance(const T* a, const T* b) {
  T bc[4], d[4];
  quat_conj(bc, b);
  mul_quat(d, a, bc);
  return T(2) * asin(min(norm3(d + 1), T(1)));
}

// Roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll), each wrapped to [0, 2 pi).
template <class T>
BIDEX_HD inline void euler_xyz(T* out, const T* q) {
  const T pi = T(kPi), two_pi = T(2 * kPi);
  const T w = q[0], x = q[1], y = q[2], z = q[3];
  const T roll = atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
  const T sp = 2 * (w * y - z * x);
  const T pitch = abs(sp) >= 1 ? copysign(pi / 2, sp) : asin(sp);
  const T yaw = atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
  const T r[3] = {roll, pitch, yaw};
  for (int k = 0; k < 3; ++k) {
    T a = fmod(r[k], two_pi);
    if (a < 0) a += two_pi;
    out[k] = a >= two_pi ? a - two_pi : a;  // a tiny negative angle rounds up to 2 pi
  }
}

// The original's random orientation: rotation about x by pi r0, then about y by pi r1,
// r ~ U(-1, 1), composed as q_x * q_y.
template <class T>
BIDEX_HD inline void random_rotation(T* out, SlotRng& rng) {
  const double r0 = rng.uniform(-1, 1), r1 = rng.uniform(-1, 1);
  const T ax[3] = {1, 0, 0}, ay[3] = {0, 1, 0};
  T qx[4], qy[4];
  axis_angle_quat(qx, ax, T(kPi * r0));
  axis_angle_quat(qy, ay, T(kPi * r1));
  mul_quat(out, qx, qy);
}

}  // namespace bidex::tasks::math
