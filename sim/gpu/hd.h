// Host/device portability of the GPU engine. Every stage function is written once and compiled
// twice: by g++ for the host (CI runs the parity tests on it) and by nvcc for the GPU.
//   BIDEX_HD  marks a function for both sides; it is empty when nvcc is not compiling.
//   Lanes     is the group of threads that work on one world together: on the GPU 4 to 32
//             lanes of one warp, on the host one thread (or, in tests, a group of host threads
//             standing in for the lanes). Stage functions split per-body, per-dof and
//             per-constraint loops over the lanes and call sync() between dependent phases.
#pragma once

#include <math.h>

#if defined(__CUDACC__)
#define BIDEX_HD __host__ __device__
#else
#define BIDEX_HD
#endif

namespace bidex::sim::gpu {

// A group of host threads standing in for the lanes of one world (engine.cc): the parity tests
// run the stage functions split over several lanes on the host, so CI checks the lane logic of
// the kernels without a GPU.
struct HostLaneGroup;
void host_lane_sync(HostLaneGroup* group);
double host_lane_reduce(HostLaneGroup* group, int id, double v, bool take_max);

struct Lanes {
  int id = 0;         // this thread's lane, 0 .. n-1
  int n = 1;          // lanes per world (a power of two, at most 32)
  unsigned mask = 1;  // the group's lanes within its warp (device only)
  HostLaneGroup* host = nullptr;  // host emulation of n > 1 lanes (host only)

  // Barrier and memory fence among the group's lanes.
  BIDEX_HD void sync() const {
#if defined(__CUDA_ARCH__)
    __syncwarp(mask);
#else
    if (host) host_lane_sync(host);
#endif
  }

  // Sum of v over the group's lanes, the same value returned to every lane; the summation
  // order is a fixed butterfly, so results do not depend on scheduling.
  template <class T>
  BIDEX_HD T sum(T v) const {
#if defined(__CUDA_ARCH__)
    for (int off = n / 2; off > 0; off >>= 1) v += __shfl_xor_sync(mask, v, off);
#else
    if (host) v = static_cast<T>(host_lane_reduce(host, id, static_cast<double>(v), false));
#endif
    return v;
  }

  // Largest v over the group's lanes, returned to every lane.
  template <class T>
  BIDEX_HD T max(T v) const {
#if defined(__CUDA_ARCH__)
    for (int off = n / 2; off > 0; off >>= 1) {
      T o = __shfl_xor_sync(mask, v, off);
      v = o > v ? o : v;
    }
#else
    if (host) v = static_cast<T>(host_lane_reduce(host, id, static_cast<double>(v), true));
#endif
    return v;
  }
};

// Scalar functions with one name for float and double, usable on both sides.
BIDEX_HD inline double g_sqrt(double x) { return sqrt(x); }
BIDEX_HD inline float g_sqrt(float x) { return sqrtf(x); }
BIDEX_HD inline double g_sin(double x) { return sin(x); }
BIDEX_HD inline float g_sin(float x) { return sinf(x); }
BIDEX_HD inline double g_cos(double x) { return cos(x); }
BIDEX_HD inline float g_cos(float x) { return cosf(x); }
BIDEX_HD inline double g_atan2(double y, double x) { return atan2(y, x); }
BIDEX_HD inline float g_atan2(float y, float x) { return atan2f(y, x); }
BIDEX_HD inline double g_pow(double x, double y) { return pow(x, y); }
BIDEX_HD inline float g_pow(float x, float y) { return powf(x, y); }
BIDEX_HD inline double g_abs(double x) { return fabs(x); }
BIDEX_HD inline float g_abs(float x) { return fabsf(x); }
BIDEX_HD inline bool g_finite(double x) { return isfinite(x); }
BIDEX_HD inline bool g_finite(float x) { return isfinite(x); }
template <class T>
BIDEX_HD inline T g_min(T a, T b) { return a < b ? a : b; }
template <class T>
BIDEX_HD inline T g_max(T a, T b) { return a > b ? a : b; }
template <class T>
BIDEX_HD inline T g_clip(T x, T lo, T hi) { return x < lo ? lo : (x > hi ? hi : x); }

// MuJoCo 2.2.2's numeric guards (mjMINVAL, mjMINIMP, mjMAXIMP).
constexpr double kMinVal = 1e-15;
constexpr double kMinImp = 1e-4;
constexpr double kMaxImp = 0.9999;
constexpr double kPi = 3.14159265358979323846;

}  // namespace bidex::sim::gpu
