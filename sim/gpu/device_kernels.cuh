// The CUDA kernels of the GPU engine and CudaEngine<T>, the DeviceEngine that owns the device
// memory; included by one .cu file per precision (device_f32.cu, device_f64.cu) so that the
// two compile in parallel.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>
#include <algorithm>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim/gpu/data.h"
#include "sim/gpu/device_engine.h"
#include "sim/gpu/step.h"

namespace bidex::sim::gpu::detail {

inline void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw std::runtime_error(std::string("CUDA: ") + what + ": " + cudaGetErrorString(e));
}

constexpr int kBlock = 128;  // threads per block: 128 / lanes worlds

// This thread's lane group: its lanes, the first world it serves and the stride to the next
// (a grid smaller than the world count walks the worlds in turns; all lanes of a group see the
// same worlds, so no barrier is left waiting).
__device__ inline Lanes lane_group(int L, int* first, int* stride) {
  Lanes ln;
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  *first = t / L;
  *stride = gridDim.x * blockDim.x / L;
  ln.id = threadIdx.x % L;
  ln.n = L;
  const int warp_lane = threadIdx.x % 32;
  ln.mask = L == 32 ? 0xffffffffu : (((1u << L) - 1u) << (warp_lane / L * L));
  return ln;
}

// Stages launched one by one (forward() and the stage timings), in pipeline order.
enum StageId : int {
  kStKinematics,
  kStComPos,
  kStTendon,
  kStCrb,
  kStFactorM,
  kStMakeConstraint,
  kStTransmission,
  kStFwdVelocity,
  kStFwdActuation,
  kStFwdAcceleration,
  kStFwdConstraint,
  kStEuler,
  kStCount
};
const char* const kStageNames[kStCount] = {
    "kinematics",      "com_pos",       "tendon",         "crb",
    "factor_m",        "make_constraint", "transmission", "fwd_velocity",
    "fwd_actuation",   "fwd_acceleration", "fwd_constraint", "euler"};

template <class T>
__global__ void __launch_bounds__(kBlock) stage_kernel(Model<T> m, Data<T> data, int lanes,
                                                       int stage) {
  int first, stride;
  const Lanes ln = lane_group(lanes, &first, &stride);
  for (int w = first; w < data.nworld; w += stride) {
    const World<T> d = data.world(w);
    switch (stage) {
      case kStKinematics: kinematics(m, d, ln, true); break;
      case kStComPos: com_pos(m, d, ln); break;
      case kStTendon: tendon(m, d, ln); break;
      case kStCrb: crb(m, d, ln); break;
      case kStFactorM: factor_m(m, d, ln); break;
      case kStMakeConstraint: make_constraint(m, d, ln); break;
      case kStTransmission: transmission(m, d, ln); break;
      case kStFwdVelocity: fwd_velocity(m, d, ln); break;
      case kStFwdActuation: fwd_actuation(m, d, ln); break;
      case kStFwdAcceleration: fwd_acceleration(m, d, ln); break;
      case kStFwdConstraint: fwd_constraint(m, d, ln); break;
      case kStEuler:
        euler(m, d, ln);
        check_finite(m, d, ln);
        break;
      default: break;
    }
  }
}

// `substeps` physics steps of every world in one launch; with `observe`, a final position and
// velocity pass (poses, inertias, cvel) for the state the steps ended in.
template <class T>
__global__ void __launch_bounds__(kBlock) step_kernel(Model<T> m, Data<T> data, int lanes,
                                                      int substeps, int observe) {
  int first, stride;
  const Lanes ln = lane_group(lanes, &first, &stride);
  for (int w = first; w < data.nworld; w += stride) {
    const World<T> d = data.world(w);
    for (int k = 0; k < substeps; ++k) step(m, d, ln, /*poses=*/false);
    if (observe) {
      kinematics(m, d, ln, /*poses=*/true);
      com_pos(m, d, ln);
      com_vel(m, d, ln);
    }
  }
}

// a uniform number in [0, 1) from a hash of (seed, a, b)
__device__ inline double hash_uniform(uint64_t seed, uint64_t a, uint64_t b) {
  uint64_t z = seed + 0x9e3779b97f4a7c15ull * (a + 1) + 0xbf58476d1ce4e5b9ull * (b + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53;
}

// random controls: uniform in the control range (or [-1, 1] when unlimited), one thread per world
template <class T>
__global__ void random_ctrl(Model<T> m, Data<T> data, uint64_t seed) {
  const int w = blockIdx.x * blockDim.x + threadIdx.x;
  if (w >= data.nworld) return;
  const World<T> d = data.world(w);
  for (int a = 0; a < m.s.nu; ++a) {
    const bool lim = m.actuator_ctrllimited[a];
    const double lo = lim ? static_cast<double>(m.actuator_ctrlrange[2 * a]) : -1.0;
    const double hi = lim ? static_cast<double>(m.actuator_ctrlrange[2 * a + 1]) : 1.0;
    d.ctrl[a] = static_cast<T>(lo + (hi - lo) * hash_uniform(seed, w, a));
  }
}

// reference pose at rest, applied forces from a table (may be null), time and faults cleared
template <class T>
__global__ void reset_kernel(Model<T> m, Data<T> data, const T* xfrc) {
  const int w = blockIdx.x * blockDim.x + threadIdx.x;
  if (w >= data.nworld) return;
  const World<T> d = data.world(w);
  for (int i = 0; i < m.s.nq; ++i) d.qpos[i] = m.qpos0[i];
  for (int i = 0; i < m.s.nv; ++i) d.qvel[i] = d.qacc_warmstart[i] = d.qfrc_applied[i] = 0;
  for (int i = 0; i < 6 * m.s.nbody; ++i) d.xfrc_applied[i] = xfrc ? xfrc[i] : T(0);
  d.time[0] = 0;
  d.fault[0] = 0;
}

// fault words of all worlds summed into one counter
static __global__ void count_faults(const int* fault, int nworld, int* count) {
  const int w = blockIdx.x * blockDim.x + threadIdx.x;
  if (w < nworld && fault[w] != 0) atomicAdd(count, 1);
}

template <class T>
class CudaEngine final : public DeviceEngine {
 public:
  CudaEngine(const ModelArrays& arrays, int nworld, int lanes)
      : nworld_(nworld), lanes_(lanes), packed_(arrays),
        bytes_(layout_bytes<T>(arrays.s, nworld)) {
    if (lanes != 4 && lanes != 8 && lanes != 16 && lanes != 32)
      throw std::runtime_error("GPU engine: lanes per world must be 4, 8, 16 or 32, got " +
                               std::to_string(lanes));
    if (cuda_device_count() == 0) throw std::runtime_error("CUDA: no device");
    // model: one block, one copy
    const auto& bytes = packed_.bytes();
    check(cudaMalloc(&dmodel_, bytes.size()), "cudaMalloc(model)");
    check(cudaMemcpy(dmodel_, bytes.data(), bytes.size(), cudaMemcpyHostToDevice), "copy model");
    model_ = packed_.view(dmodel_);
    // worlds: one block, laid out like the host staging copy (made when first needed)
    check(cudaMalloc(&ddata_, bytes_), "cudaMalloc(worlds)");
    check(cudaMemset(ddata_, 0, bytes_), "cudaMemset(worlds)");
    data_ = layout<T>(arrays.s, nworld, ddata_);
    check(cudaEventCreate(&start_), "event");
    check(cudaEventCreate(&stop_), "event");
    check(cudaMalloc(&dcount_, sizeof(int)), "cudaMalloc(count)");
  }
  ~CudaEngine() override {
    cudaFree(dmodel_);
    cudaFree(ddata_);
    cudaFree(dcount_);
    cudaEventDestroy(start_);
    cudaEventDestroy(stop_);
  }

  int nworld() const override { return nworld_; }
  const Sizes& sizes() const override { return model_.s; }
  HostData<double>& mirror() override {
    if (!mirror_) {
      mirror_ = std::make_unique<HostData<double>>(model_.s, nworld_);
      staging_.resize(bytes_);
      host_ = layout<T>(model_.s, nworld_, staging_.data());
    }
    return *mirror_;
  }
  void upload() override {
    copy_fields(mirror().data(), host_);
    check(cudaMemcpy(ddata_, staging_.data(), bytes_, cudaMemcpyHostToDevice), "upload");
  }
  void download() override {
    mirror();
    check(cudaMemcpy(staging_.data(), ddata_, bytes_, cudaMemcpyDeviceToHost), "download");
    copy_fields(host_, mirror_->data());
  }
  void forward() override {
    for (int s = 0; s <= kStFwdConstraint; ++s) launch_stage(s);
    check(cudaDeviceSynchronize(), "forward");
  }
  void step(int n) override {
    launch_step(n, 0);
    check(cudaDeviceSynchronize(), "step");
  }
  std::string describe() const override {
    return std::string("cuda ") + (sizeof(T) == 8 ? "float64" : "float32") + ", " +
           std::to_string(lanes_) + " lanes per world";
  }

  int lanes() const override { return lanes_; }
  void set_resident_blocks_per_sm(int n) override {
    int dev = 0, sms = 0;
    check(cudaGetDevice(&dev), "device");
    check(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev), "SM count");
    cap_blocks_ = n > 0 ? n * sms : 0;
  }
  int resident_blocks_per_sm() const override {
    int dev = 0, sms = 1;
    cudaGetDevice(&dev);
    cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev);
    return cap_blocks_ > 0 ? cap_blocks_ / sms : 0;
  }
  size_t state_bytes() const override { return bytes_; }
  size_t model_bytes() const override { return packed_.bytes().size(); }

  void reset_worlds(const std::vector<double>& xfrc, uint64_t seed) override {
    T* dx = nullptr;
    if (!xfrc.empty()) {
      if (xfrc.size() != static_cast<size_t>(6 * model_.s.nbody))
        throw std::runtime_error("GPU engine: xfrc table must hold nbody x 6 values");
      std::vector<T> t(xfrc.begin(), xfrc.end());
      check(cudaMalloc(&dx, sizeof(T) * t.size()), "cudaMalloc(xfrc)");
      check(cudaMemcpy(dx, t.data(), sizeof(T) * t.size(), cudaMemcpyHostToDevice), "xfrc");
    }
    const int blocks = (nworld_ + 127) / 128;
    reset_kernel<T><<<blocks, 128>>>(model_, data_, dx);
    check(cudaGetLastError(), "reset_kernel");
    random_ctrl<T><<<blocks, 128>>>(model_, data_, seed);
    check(cudaGetLastError(), "random_ctrl");
    check(cudaDeviceSynchronize(), "reset");
    cudaFree(dx);
  }

  double time_steps(int launches, int substeps, bool observe, uint64_t seed) override {
    const int blocks = (nworld_ + 127) / 128;
    check(cudaEventRecord(start_), "event");
    for (int k = 0; k < launches; ++k) {
      random_ctrl<T><<<blocks, 128>>>(model_, data_, seed + k);
      launch_step(substeps, observe ? 1 : 0);
    }
    check(cudaEventRecord(stop_), "event");
    check(cudaEventSynchronize(stop_), "steps");
    float ms = 0;
    check(cudaEventElapsedTime(&ms, start_, stop_), "event");
    return ms * 1e-3;
  }

  std::vector<std::pair<std::string, double>> time_stages(int repeats) override {
    std::vector<std::pair<std::string, double>> out;
    forward();
    for (int s = 0; s < kStCount; ++s) {
      if (s == kStEuler) continue;  // it would advance the state under the other stages
      check(cudaEventRecord(start_), "event");
      for (int r = 0; r < repeats; ++r) launch_stage(s);
      check(cudaEventRecord(stop_), "event");
      check(cudaEventSynchronize(stop_), "stages");
      float ms = 0;
      check(cudaEventElapsedTime(&ms, start_, stop_), "event");
      out.push_back({kStageNames[s], ms * 1e-3 / repeats});
    }
    return out;
  }

  double mean_solver_iterations() override {
    std::vector<int> it(nworld_);
    check(cudaMemcpy(it.data(), data_.solver_niter, sizeof(int) * nworld_, cudaMemcpyDeviceToHost),
          "solver iterations");
    double sum = 0;
    for (int v : it) sum += v;
    return nworld_ ? sum / nworld_ : 0.0;
  }

  int faulty_worlds() override {
    check(cudaMemset(dcount_, 0, sizeof(int)), "cudaMemset");
    count_faults<<<(nworld_ + 255) / 256, 256>>>(data_.fault, nworld_, dcount_);
    check(cudaGetLastError(), "count_faults");
    int n = 0;
    check(cudaMemcpy(&n, dcount_, sizeof(int), cudaMemcpyDeviceToHost), "fault count");
    return n;
  }

 private:
  int grid() const {
    const int all = static_cast<int>((static_cast<long>(nworld_) * lanes_ + kBlock - 1) / kBlock);
    return cap_blocks_ > 0 ? std::min(all, cap_blocks_) : all;
  }
  void launch_stage(int s) {
    stage_kernel<T><<<grid(), kBlock>>>(model_, data_, lanes_, s);
    check(cudaGetLastError(), kStageNames[s]);
  }
  void launch_step(int substeps, int observe) {
    step_kernel<T><<<grid(), kBlock>>>(model_, data_, lanes_, substeps, observe);
    check(cudaGetLastError(), "step_kernel");
  }

  int nworld_;
  int lanes_;
  int cap_blocks_ = 0;  // 0: one thread group per world; else at most this many blocks
  PackedModel<T> packed_;
  size_t bytes_;  // of the worlds' block
  std::unique_ptr<HostData<double>> mirror_;
  std::vector<std::byte> staging_;
  std::byte* dmodel_ = nullptr;
  std::byte* ddata_ = nullptr;
  int* dcount_ = nullptr;
  Model<T> model_;
  Data<T> data_;  // device pointers
  Data<T> host_{};  // the staging copy's pointers
  cudaEvent_t start_{}, stop_{};
};

}  // namespace bidex::sim::gpu::detail
