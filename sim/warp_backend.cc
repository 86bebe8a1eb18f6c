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
    : WarpBackend(std::vector<const SimModel*>{&model}, std::vector<int>{nworld},
                  std::move(options)) {}
WarpBackend::WarpBackend(const std::vector<const SimModel*>& scenes, const std::vector<int>&,
                         WarpOptions options)
    : model_(scenes.empty() ? nullptr : scenes[0]), options_(std::move(options)) {
  throw DeviceError(warp_missing());
}
std::vector<int> WarpBackend::topology_groups(const std::vector<const SimModel*>&) {
  throw DeviceError(warp_missing());
}
WorldArray WarpBackend::rows(const std::string&, int, int) const { return {}; }
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
void WarpBackend::download_bytes(const std::string&, void*, size_t, int) const {}
void WarpBackend::upload_bytes(const std::string&, const void*, size_t, int) {}
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

namespace {

// The hands' base bodies a base wrench acts on (-1: a fixed base).
std::vector<int> root_bodies(const SimModel& model) {
  std::vector<int> roots;
  for (const auto& h : model.hands()) roots.push_back(h.free_base ? h.root_body : -1);
  return roots;
}

// The scenes' compiled models as temporary files, removed with this object.
struct SavedModels {
  std::vector<std::string> paths;
  explicit SavedModels(const std::vector<const SimModel*>& scenes) {
    for (const SimModel* s : scenes) paths.push_back(save_model(s->mj()));
  }
  ~SavedModels() {
    for (const auto& p : paths) std::remove(p.c_str());
  }
};

}  // namespace

WarpBackend::WarpBackend(const SimModel& model, int nworld, WarpOptions options)
    : WarpBackend(std::vector<const SimModel*>{&model}, std::vector<int>{nworld},
                  std::move(options)) {}

WarpBackend::WarpBackend(const std::vector<const SimModel*>& scenes,
                         const std::vector<int>& worlds, WarpOptions options)
    : model_(scenes.empty() ? nullptr : scenes[0]), scene_worlds_(worlds),
      options_(std::move(options)), impl_(new Impl) {
  if (scenes.empty() || scenes.size() != worlds.size())
    throw Error("GPU backend: " + std::to_string(scenes.size()) + " scenes and " +
                std::to_string(worlds.size()) + " world counts; expected one count per scene");
  const SimModel& model = *scenes[0];
  int njmax = 0, nconmax = 0;
  for (size_t k = 0; k < scenes.size(); ++k) {
    if (worlds[k] < 1)
      throw Error("GPU backend: nworld must be >= 1, got " + std::to_string(worlds[k]) +
                  (scenes.size() > 1 ? " for scene " + std::to_string(k) : ""));
    nworld_ += worlds[k];
    const PhysicsOptions& p = scenes[k]->physics();
    njmax = std::max(njmax, p.gpu.njmax);
    nconmax = std::max(nconmax, p.gpu.nconmax);
    auto differ = [&](const std::string& what, const std::string& a, const std::string& b) {
      throw Error("GPU backend: scenes 0 and " + std::to_string(k) + " cannot share worlds: " +
                  what + " " + a + " against " + b);
    };
    if (p.substeps != model.physics().substeps)
      differ("substeps", std::to_string(model.physics().substeps), std::to_string(p.substeps));
    if (p.max_speed != model.physics().max_speed)
      differ("max_speed", std::to_string(model.physics().max_speed),
             std::to_string(p.max_speed));
    if (root_bodies(*scenes[k]) != root_bodies(model))
      differ("hand bases (free or fixed, root bodies)", "scene 0's",
             "scene " + std::to_string(k) + "'s");
  }
  if (options_.njmax <= 0) options_.njmax = njmax;
  if (options_.nconmax <= 0) options_.nconmax = nconmax;
  if (options_.device.rfind("cuda", 0) == 0) require_gpu();
  ensure_python();
  py::gil_scoped_acquire gil;
  py::module_ mod = import_bridge();

  const SavedModels mjb(scenes);
  try {
    impl_->bridge = mod.attr("Bridge")(mjb.paths, worlds, model.physics().substeps,
                                       options_.njmax, options_.nconmax,
                                       model.physics().max_speed, root_bodies(model),
                                       options_.device, options_.sensors_every_substep);
  } catch (const py::error_already_set& e) {
    throw DeviceError("GPU backend: MuJoCo Warp could not set up " + std::to_string(nworld_) +
                      " worlds" +
                      (scenes.size() > 1 ? " of " + std::to_string(scenes.size()) + " scenes" : "") +
                      " on '" + options_.device + "': " + describe(e));
  }

  auto arrays = impl_->bridge.attr("arrays")().cast<std::map<std::string, py::tuple>>();
  for (auto& [name, t] : arrays)
    impl_->arrays[name] = {t[0].cast<uintptr_t>(), t[1].cast<int>(), t[2].cast<int>(),
                           t[3].cast<size_t>()};
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

std::vector<int> WarpBackend::topology_groups(const std::vector<const SimModel*>& scenes) {
  ensure_python();
  py::gil_scoped_acquire gil;
  py::module_ mod = import_bridge();
  const SavedModels mjb(scenes);
  try {
    return mod.attr("topology_groups")(mjb.paths).cast<std::vector<int>>();
  } catch (const py::error_already_set& e) {
    throw DeviceError("GPU backend: comparing " + std::to_string(scenes.size()) +
                      " scenes' MuJoCo Warp models failed: " + describe(e));
  }
}

bool WarpBackend::on_gpu() const { return impl_->gpu; }

WorldArray WarpBackend::array(const std::string& name) const {
  auto it = impl_->arrays.find(name);
  if (it == impl_->arrays.end()) throw Error("GPU backend: no array named '" + name + "'");
  return it->second;
}

WorldArray WarpBackend::rows(const std::string& name, int first, int count) const {
  WorldArray a = array(name);
  if (first < 0 || count < 0 || first + count > a.rows)
    throw Error("GPU backend: rows " + std::to_string(first) + " to " +
                std::to_string(first + count) + " of '" + name + "', which has " +
                std::to_string(a.rows));
  a.ptr += static_cast<uintptr_t>(first) * a.row_bytes;
  a.rows = count;
  return a;
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

namespace {

// The address of row `first_row` of `a`, checked against copying `bytes` from there.
uintptr_t copy_address(const std::string& name, const WorldArray& a, size_t bytes,
                       int first_row) {
  const size_t start = static_cast<size_t>(std::max(first_row, 0)) * a.row_bytes;
  const size_t size = static_cast<size_t>(a.rows) * a.row_bytes;
  if (first_row < 0 || start + bytes > size)
    throw Error("GPU backend: a copy of " + std::to_string(bytes) + " bytes from row " +
                std::to_string(first_row) + " of '" + name + "' passes its end (" +
                std::to_string(size) + " bytes)");
  return a.ptr + start;
}

}  // namespace

void WarpBackend::download_bytes(const std::string& name, void* dst, size_t bytes,
                                 int first_row) const {
  WorldArray a = array(name);
  a.ptr = copy_address(name, a, bytes, first_row);
  if (impl_->gpu) {
    cuda::copy_to_host(impl_->stream, dst, a.ptr, bytes);
  } else {
    const_cast<WarpBackend*>(this)->synchronize();
    std::memcpy(dst, reinterpret_cast<const void*>(a.ptr), bytes);
  }
}

void WarpBackend::upload_bytes(const std::string& name, const void* src, size_t bytes,
                               int first_row) {
  WorldArray a = array(name);
  a.ptr = copy_address(name, a, bytes, first_row);
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
  return impl_->arrays[name] = {ptr, rows, width, static_cast<size_t>(std::max<size_t>(width * elem_bytes, 1))};
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
  uint32_t seen = 0;
  for (uint32_t bits : download_as<uint32_t>("overflow_seen")) seen |= bits;
  std::string kinds, keys;
  const auto add = [](std::string& list, const char* item) {
    list.append(list.empty() ? "" : " and ").append(item);
  };
  if (seen & kOverflowRows) add(kinds, "constraint rows");
  if (seen & kOverflowContacts) add(kinds, "contacts");
  if (seen & kOverflowOther) add(kinds, "other buffers");
  if (seen & (kOverflowRows | kOverflowOther)) add(keys, "gpu.njmax");
  if (seen & (kOverflowContacts | kOverflowOther)) add(keys, "gpu.nconmax");
  return std::to_string(n) + " steps of worlds overflowed their room on the GPU (" + kinds +
         "; the room: " + std::to_string(options_.njmax) + " constraint rows, " +
         std::to_string(options_.nconmax) + " contacts per world; up to " +
         std::to_string(max_rows()) + " rows were needed; each was reset): raise " + keys +
         " in the physics YAML (configs/sim/physics.yaml, or the task's scene)";
}

}  // namespace bidex::sim
