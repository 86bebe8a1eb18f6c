#include "sim/warp_backend.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <unistd.h>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "sim/batch.h"
#include "sim/cuda_driver.h"

#ifdef BIDEX_WARP
#include <pybind11/embed.h>
#include <pybind11/stl.h>
namespace py = pybind11;
#endif

namespace bidex::sim {
namespace {

const char* kInstall =
    "run scripts/setup.sh --gpu (it pip-installs the pinned warp-lang and mujoco-warp into "
    ".venv/), or on a machine without package access scripts/offline-build.sh (README, 'With a "
    "GPU')";

}  // namespace

#ifndef BIDEX_WARP

bool warp_built() { return false; }
std::string warp_missing() {
  return "this build of bidex has no GPU backend: it was configured without Python's embedding "
         "headers (Debian: python3-dev, pybind11-dev); install them and rebuild (scripts/setup.sh "
         "does both)";
}

struct WarpBackend::Impl {};

WarpBackend::WarpBackend(const SimModel& model, int nworld, WarpOptions options)
    : model_(&model), nworld_(nworld), options_(std::move(options)) {
  throw DeviceError(warp_missing());
}
WarpBackend::~WarpBackend() = default;
bool WarpBackend::on_gpu() const { return false; }
WorldArray WarpBackend::array(const std::string&) const { return {}; }
void WarpBackend::step() {}
void WarpBackend::reset_begin() {}
void WarpBackend::reset_end() {}
void WarpBackend::random_inputs(uint64_t, int64_t, double, double) {}
void WarpBackend::raw_step() {}
void WarpBackend::random_fill(const std::string&, uint64_t, int64_t, float, float) {}
void WarpBackend::synchronize() {}
void WarpBackend::download_bytes(const std::string&, void*, size_t) const {}
void WarpBackend::upload_bytes(const std::string&, const void*, size_t) {}
WorldArray WarpBackend::allocate(const std::string&, int, size_t, int) { return {}; }
uintptr_t WarpBackend::stream() const { return 0; }
size_t WarpBackend::device_bytes() const { return 0; }
std::map<std::string, double> WarpBackend::phase_profile(int) { return {}; }

#else

bool warp_built() { return true; }
std::string warp_missing() { return ""; }

namespace {

// One interpreter per process: in the bidex command and the tests, started on first use and
// never finalized (Warp and the CUDA driver hold state to the end of the process), the GIL
// released between calls; in the Python module (python/), the interpreter that imported it,
// whose own packages come first (the build's are appended as a fallback).
void ensure_python() {
  static std::once_flag once;
  std::call_once(once, [] {
    const bool host = Py_IsInitialized();
    if (!host) py::initialize_interpreter(false);
    {
      py::gil_scoped_acquire gil;
      py::list path = py::module_::import("sys").attr("path");
      auto add = [&](const char* dir) {
        if (host) path.append(dir); else path.insert(0, dir);
      };
      // the packages (mujoco, warp, mujoco_warp) and the bridge beside this file
      add(BIDEX_PYTHON_SITE);
      if (const char* extra = std::getenv("BIDEX_PYTHON_SITE")) add(extra);
      add(BIDEX_SOURCE_DIR "/sim");
    }
    if (!host) PyEval_SaveThread();
  });
}

// A Python exception as one line: its type and message.
std::string describe(const py::error_already_set& e) {
  std::string what = e.what();
  const auto nl = what.find('\n');
  return nl == std::string::npos ? what : what.substr(0, nl);
}

py::module_ import_bridge() {
  for (const char* pkg : {"mujoco", "warp", "mujoco_warp"}) {
    try {
      py::module_::import(pkg);
    } catch (const py::error_already_set& e) {
      throw DeviceError(std::string("GPU backend: Python package '") + pkg +
                        "' did not import from " + BIDEX_PYTHON_SITE + " (" + describe(e) +
                        "): " + kInstall);
    }
  }
  return py::module_::import("warp_bridge");
}

// The compiled model as MuJoCo's binary file, which the bridge loads (same library version).
std::string save_model(const mjModel* m) {
  char path[] = "/tmp/bidex-model-XXXXXX.mjb";
  const int fd = mkstemps(path, 4);
  if (fd < 0) throw IoError(std::string("cannot create a temporary model file in /tmp: ") +
                            std::strerror(errno));
  close(fd);
  mj_saveModel(m, path, nullptr, 0);
  return path;
}

}  // namespace

// The bridge's passes, captured as graphs on a GPU (warp_bridge.py names them).
enum Pass { kStep, kResetBegin, kResetEnd, kRawStep, kPasses };
constexpr const char* kPassNames[kPasses] = {"step", "reset_begin", "reset_end", "raw_step"};

struct WarpBackend::Impl {
  py::object bridge;
  std::map<std::string, WorldArray> arrays;
  cuda::Stream stream;
  bool gpu = false;
  uintptr_t graphs[kPasses] = {};  // executable graph of each pass (GPU only)

  void run(Pass pass) {
    if (gpu) {
      cuda::launch_graph(stream, graphs[pass]);
      return;
    }
    py::gil_scoped_acquire gil;
    try {
      bridge.attr("run")(kPassNames[pass]);
    } catch (const py::error_already_set& e) {
      throw DeviceError(std::string("GPU backend: the ") + kPassNames[pass] +
                        " pass failed: " + describe(e));
    }
  }

  ~Impl() {
    if (bridge) {
      py::gil_scoped_acquire gil;
      bridge = py::object();
    }
  }
};

WarpBackend::WarpBackend(const SimModel& model, int nworld, WarpOptions options)
    : model_(&model), nworld_(nworld), options_(std::move(options)), impl_(new Impl) {
  if (nworld < 1) throw Error("GPU backend: nworld must be >= 1, got " + std::to_string(nworld));
  if (options_.njmax <= 0) options_.njmax = model.physics().gpu.njmax;
  if (options_.nconmax <= 0) options_.nconmax = model.physics().gpu.nconmax;
  if (options_.device.rfind("cuda", 0) == 0) require_gpu();
  ensure_python();
  py::gil_scoped_acquire gil;
  py::module_ mod = import_bridge();

  std::vector<int> roots;
  for (const auto& h : model.hands()) roots.push_back(h.free_base ? h.root_body : -1);
  const std::string mjb = save_model(model.mj());
  try {
    impl_->bridge = mod.attr("Bridge")(mjb, nworld, model.physics().substeps, options_.njmax,
                                       options_.nconmax, model.physics().max_speed, roots,
                                       options_.device, options_.sensors_every_substep);
  } catch (const py::error_already_set& e) {
    std::remove(mjb.c_str());
    throw DeviceError("GPU backend: MuJoCo Warp could not set up " + std::to_string(nworld) +
                      " worlds on '" + options_.device + "': " + describe(e));
  }
  std::remove(mjb.c_str());

  auto arrays = impl_->bridge.attr("arrays")().cast<std::map<std::string, py::tuple>>();
  for (auto& [name, t] : arrays)
    impl_->arrays[name] = {t[0].cast<uintptr_t>(), t[1].cast<int>(), t[2].cast<int>()};
  auto s = impl_->bridge.attr("stream")().cast<std::pair<uintptr_t, uintptr_t>>();
  impl_->stream = {s.first, s.second};
  impl_->gpu = s.second != 0 || s.first != 0;
  if (impl_->gpu) {
    for (int pass = 0; pass < kPasses; ++pass) {
      try {
        impl_->graphs[pass] =
            impl_->bridge.attr("capture")(kPassNames[pass]).cast<uintptr_t>();
      } catch (const py::error_already_set& e) {
        throw DeviceError(std::string("GPU backend: capturing the ") + kPassNames[pass] +
                          " pass as a CUDA graph failed: " + describe(e));
      }
    }
  }
}

WarpBackend::~WarpBackend() = default;

bool WarpBackend::on_gpu() const { return impl_->gpu; }

WorldArray WarpBackend::array(const std::string& name) const {
  auto it = impl_->arrays.find(name);
  if (it == impl_->arrays.end()) throw Error("GPU backend: no array named '" + name + "'");
  return it->second;
}

void WarpBackend::step() { impl_->run(kStep); }
void WarpBackend::reset_begin() { impl_->run(kResetBegin); }
void WarpBackend::reset_end() { impl_->run(kResetEnd); }
void WarpBackend::raw_step() { impl_->run(kRawStep); }

void WarpBackend::random_inputs(uint64_t seed, int64_t step, double max_force,
                                double max_torque) {
  // a benchmark's input pass: one Python launch (not part of the per-step path of training)
  py::gil_scoped_acquire gil;
  impl_->bridge.attr("random_inputs")(static_cast<int>(seed & 0x7fffffff),
                                      static_cast<int>(step & 0x7fffffff), max_force, max_torque);
}

void WarpBackend::random_fill(const std::string& name, uint64_t seed, int64_t step, float lo,
                              float hi) {
  const WorldArray a = array(name);
  py::gil_scoped_acquire gil;
  impl_->bridge.attr("random_fill")(name, a.width, static_cast<int>(seed & 0x7fffffff),
                                    static_cast<int>(step & 0x7fffffff), lo, hi);
}

void WarpBackend::synchronize() {
  if (impl_->gpu) {
    cuda::synchronize(impl_->stream);
    return;
  }
  py::gil_scoped_acquire gil;
  impl_->bridge.attr("synchronize")();
}

void WarpBackend::download_bytes(const std::string& name, void* dst, size_t bytes) const {
  const WorldArray a = array(name);
  if (impl_->gpu) {
    cuda::copy_to_host(impl_->stream, dst, a.ptr, bytes);
  } else {
    const_cast<WarpBackend*>(this)->synchronize();
    std::memcpy(dst, reinterpret_cast<const void*>(a.ptr), bytes);
  }
}

void WarpBackend::upload_bytes(const std::string& name, const void* src, size_t bytes) {
  const WorldArray a = array(name);
  if (impl_->gpu) {
    cuda::copy_to_device(impl_->stream, a.ptr, src, bytes);
  } else {
    synchronize();
    std::memcpy(reinterpret_cast<void*>(a.ptr), src, bytes);
  }
}

WorldArray WarpBackend::allocate(const std::string& name, int width, size_t elem_bytes,
                                 int rows) {
  if (impl_->arrays.count(name))
    throw Error("GPU backend: an array named '" + name + "' exists already");
  if (rows <= 0) rows = nworld_;
  py::gil_scoped_acquire gil;
  const auto ptr =
      impl_->bridge.attr("alloc")(name, static_cast<int64_t>(width * elem_bytes), rows)
          .cast<uintptr_t>();
  return impl_->arrays[name] = {ptr, rows, width};
}

uintptr_t WarpBackend::stream() const { return impl_->gpu ? impl_->stream.stream : 0; }

size_t WarpBackend::device_bytes() const {
  py::gil_scoped_acquire gil;
  return impl_->bridge.attr("memory")().cast<size_t>();
}

std::map<std::string, double> WarpBackend::phase_profile(int steps) {
  py::gil_scoped_acquire gil;
  try {
    return impl_->bridge.attr("phase_profile")(steps).cast<std::map<std::string, double>>();
  } catch (const py::error_already_set& e) {
    throw Error("GPU backend: the phase profile failed: " + describe(e));
  }
}

#endif  // BIDEX_WARP

void require_gpu() {
  if (!warp_built()) throw DeviceError(warp_missing());
  if (!cuda::driver_available())
    throw DeviceError("--device cuda: no NVIDIA driver on this machine (libcuda.so.1 did not "
                      "load); use --device cpu");
}

void WarpBackend::upload(const std::string& name, const std::vector<float>& values) {
  const WorldArray a = array(name);
  const size_t n = static_cast<size_t>(a.rows) * a.width;
  if (values.size() != n)
    throw Error("GPU backend: upload to '" + name + "' needs " + std::to_string(n) +
                " values, got " + std::to_string(values.size()));
  upload_bytes(name, values.data(), n * sizeof(float));
}

std::vector<float> WarpBackend::download(const std::string& name) const {
  return download_as<float>(name);
}

int64_t WarpBackend::total_faults() const {
  int64_t n = 0;
  for (int64_t c : download_as<int64_t>("fault_count")) n += c;
  return n;
}

int64_t WarpBackend::total_overflows() const {
  int64_t n = 0;
  for (int64_t c : download_as<int64_t>("overflow_count")) n += c;
  return n;
}

std::map<std::string, int64_t> WarpBackend::fault_kinds() const {
  int64_t worlds[kFaultKinds] = {};
  for (uint32_t bits : download_as<uint32_t>("fault_seen"))
    for (int k = 0; k < kFaultKinds; ++k) worlds[k] += (bits >> k) & 1u;
  std::map<std::string, int64_t> out;
  for (int k = 0; k < kFaultKinds; ++k)
    if (worlds[k]) out[fault_kind_name(k)] = worlds[k];
  return out;
}

int WarpBackend::max_rows() const {
  int m = 0;
  for (int32_t r : download_as<int32_t>("rows_max")) m = std::max(m, static_cast<int>(r));
  return m;
}

std::string WarpBackend::room_advice() const {
  const int64_t n = total_overflows();
  if (n == 0) return "";
  return std::to_string(n) + " steps of worlds overflowed their room on the GPU (" +
         std::to_string(options_.njmax) + " constraint rows, " + std::to_string(options_.nconmax) +
         " contacts per world; up to " + std::to_string(max_rows()) +
         " rows were needed; each was reset): raise gpu.njmax or gpu.nconmax in the physics "
         "YAML (configs/sim/physics.yaml, or the task's scene)";
}

}  // namespace bidex::sim
