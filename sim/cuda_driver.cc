#include "sim/cuda_driver.h"

#include <dlfcn.h>

#include <mutex>
#include <string>

#include "core/error.h"

namespace bidex::sim::cuda {
namespace {

// CUresult and the handle types, as the driver API declares them (cuda.h is not needed)
using Result = int;
using Ptr = void*;

struct Driver {
  void* lib = nullptr;
  Result (*ctx_push)(Ptr) = nullptr;
  Result (*ctx_pop)(Ptr*) = nullptr;
  Result (*graph_launch)(Ptr, Ptr) = nullptr;
  Result (*stream_sync)(Ptr) = nullptr;
  Result (*copy_dtoh)(void*, uintptr_t, size_t, Ptr) = nullptr;
  Result (*copy_htod)(uintptr_t, const void*, size_t, Ptr) = nullptr;
  Result (*error_string)(Result, const char**) = nullptr;
};

template <class F>
void bind(void* lib, const char* name, F*& f) {
  f = reinterpret_cast<F*>(dlsym(lib, name));
  if (!f)
    throw DeviceError(std::string("CUDA driver (libcuda.so.1) lacks ") + name +
                      ": update the NVIDIA driver");
}

const Driver& driver() {
  static Driver d;
  static std::once_flag once;
  static std::string failure;
  std::call_once(once, [] {
    d.lib = dlopen("libcuda.so.1", RTLD_NOW | RTLD_GLOBAL);
    if (!d.lib) {
      failure = "no CUDA driver: libcuda.so.1 did not load (" + std::string(dlerror()) +
                "); the GPU backend needs an NVIDIA GPU and its driver";
      return;
    }
    try {
      bind(d.lib, "cuCtxPushCurrent_v2", d.ctx_push);
      bind(d.lib, "cuCtxPopCurrent_v2", d.ctx_pop);
      bind(d.lib, "cuGraphLaunch", d.graph_launch);
      bind(d.lib, "cuStreamSynchronize", d.stream_sync);
      bind(d.lib, "cuMemcpyDtoHAsync_v2", d.copy_dtoh);
      bind(d.lib, "cuMemcpyHtoDAsync_v2", d.copy_htod);
      bind(d.lib, "cuGetErrorString", d.error_string);
    } catch (const DeviceError& e) {
      failure = e.what();
      d.lib = nullptr;
    }
  });
  if (!d.lib) throw DeviceError(failure);
  return d;
}

void check(Result r, const char* what) {
  if (r == 0) return;
  const char* msg = nullptr;
  driver().error_string(r, &msg);
  throw DeviceError(std::string("CUDA ") + what + " failed: " + (msg ? msg : "unknown error") +
                    " (code " + std::to_string(r) + ")");
}

// The backend's context is current for the duration of one call.
class Scope {
 public:
  explicit Scope(const Stream& s) { check(driver().ctx_push(ptr(s.context)), "context push"); }
  ~Scope() {
    Ptr old = nullptr;
    driver().ctx_pop(&old);
  }
  static Ptr ptr(uintptr_t h) { return reinterpret_cast<Ptr>(h); }
};

}  // namespace

bool driver_available() {
  try {
    driver();
    return true;
  } catch (const DeviceError&) {
    return false;
  }
}

void launch_graph(const Stream& s, uintptr_t graph_exec) {
  Scope scope(s);
  check(driver().graph_launch(Scope::ptr(graph_exec), Scope::ptr(s.stream)), "graph launch");
}

void synchronize(const Stream& s) {
  Scope scope(s);
  check(driver().stream_sync(Scope::ptr(s.stream)), "stream synchronize");
}

void copy_to_host(const Stream& s, void* dst, uintptr_t src, size_t bytes) {
  Scope scope(s);
  check(driver().copy_dtoh(dst, src, bytes, Scope::ptr(s.stream)), "copy to host");
  check(driver().stream_sync(Scope::ptr(s.stream)), "stream synchronize");
}

void copy_to_device(const Stream& s, uintptr_t dst, const void* src, size_t bytes) {
  Scope scope(s);
  check(driver().copy_htod(dst, src, bytes, Scope::ptr(s.stream)), "copy to device");
  check(driver().stream_sync(Scope::ptr(s.stream)), "stream synchronize");
}

}  // namespace bidex::sim::cuda
