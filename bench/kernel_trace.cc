// A CUPTI injection library: every kernel, copy and memset a CUDA program runs, with its GPU
// start and end, stream and graph, written to a text file, for programs that nsys cannot trace
// on the GPU machines (bench/kernel_trace.sh builds and runs it, bench/kernel_trace.py reads the
// file). The CUDA driver loads it at the program's first cuInit when CUDA_INJECTION64_PATH names
// it, so nothing in the traced program changes: Warp's graphs and kernels, LibTorch's, ours.
//
// KTRACE_OUT names the file. Its lines, tab-separated, times in nanoseconds on CUPTI's clock:
//   N id name                    a kernel name, before its first K line
//   K start end stream graph threads block name_id
//   C start end stream graph bytes kind   (a copy; kind is CUPTI's CUpti_ActivityMemcpyKind)
//   S start end stream graph bytes        (a memset)
//   D count                               records CUPTI dropped (its buffers overflowed)
// Records come in CUPTI's buffer order, not sorted by time.
//
// The record types are CUPTI's newest versions, which the build names from the header it finds
// (KTRACE_KERNEL, KTRACE_MEMCPY, KTRACE_MEMSET): the library that writes them is the same
// package's libcupti.
#include <cupti.h>
#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <unordered_map>

#if !defined(KTRACE_KERNEL) || !defined(KTRACE_MEMCPY) || !defined(KTRACE_MEMSET)
#error "build with bench/kernel_trace.sh build, which names CUPTI's record types"
#endif

namespace {

std::mutex mu;
FILE* out = nullptr;
std::unordered_map<std::string, int> names;

void report(CUptiResult r, const char* what) {
  if (r == CUPTI_SUCCESS) return;
  const char* text = nullptr;
  cuptiGetResultString(r, &text);
  std::fprintf(stderr, "kernel_trace: %s failed: %s\n", what, text ? text : "unknown error");
}

void CUPTIAPI requested(uint8_t** buffer, size_t* size, size_t* max_records) {
  constexpr size_t kBytes = size_t(32) << 20;
  *buffer = static_cast<uint8_t*>(std::aligned_alloc(8, kBytes));
  *size = *buffer ? kBytes : 0;
  *max_records = 0;
}

int name_id(const char* name) {
  const std::string key = name ? name : "?";
  auto [it, added] = names.emplace(key, static_cast<int>(names.size()));
  if (added) std::fprintf(out, "N\t%d\t%s\n", it->second, key.c_str());
  return it->second;
}

void CUPTIAPI completed(CUcontext ctx, uint32_t stream, uint8_t* buffer, size_t, size_t valid) {
  std::lock_guard<std::mutex> lock(mu);
  if (out) {  // null once finish() has closed it
    CUpti_Activity* r = nullptr;
    while (cuptiActivityGetNextRecord(buffer, valid, &r) == CUPTI_SUCCESS) {
      if (r->kind == CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL ||
          r->kind == CUPTI_ACTIVITY_KIND_KERNEL) {
        const auto* k = reinterpret_cast<const KTRACE_KERNEL*>(r);
        const int id = name_id(k->name);
        std::fprintf(out, "K\t%llu\t%llu\t%u\t%u\t%lld\t%d\t%d\n",
                     static_cast<unsigned long long>(k->start),
                     static_cast<unsigned long long>(k->end), k->streamId, k->graphId,
                     static_cast<long long>(k->gridX) * k->gridY * k->gridZ * k->blockX *
                         k->blockY * k->blockZ,
                     k->blockX * k->blockY * k->blockZ, id);
      } else if (r->kind == CUPTI_ACTIVITY_KIND_MEMCPY) {
        const auto* c = reinterpret_cast<const KTRACE_MEMCPY*>(r);
        std::fprintf(out, "C\t%llu\t%llu\t%u\t%u\t%llu\t%u\n",
                     static_cast<unsigned long long>(c->start),
                     static_cast<unsigned long long>(c->end), c->streamId, c->graphId,
                     static_cast<unsigned long long>(c->bytes), unsigned(c->copyKind));
      } else if (r->kind == CUPTI_ACTIVITY_KIND_MEMSET) {
        const auto* s = reinterpret_cast<const KTRACE_MEMSET*>(r);
        std::fprintf(out, "S\t%llu\t%llu\t%u\t%u\t%llu\n",
                     static_cast<unsigned long long>(s->start),
                     static_cast<unsigned long long>(s->end), s->streamId, s->graphId,
                     static_cast<unsigned long long>(s->bytes));
      }
    }
    size_t dropped = 0;
    if (cuptiActivityGetNumDroppedRecords(ctx, stream, &dropped) == CUPTI_SUCCESS && dropped)
      std::fprintf(out, "D\t%zu\n", dropped);
  }
  std::free(buffer);
}

void finish() {
  report(cuptiActivityFlushAll(CUPTI_ACTIVITY_FLAG_FLUSH_FORCED), "the last flush");
  std::lock_guard<std::mutex> lock(mu);
  if (!out) return;
  if (std::fclose(out) != 0) std::perror("kernel_trace: closing KTRACE_OUT");
  out = nullptr;
}

}  // namespace

// Called by the CUDA driver when it loads this library (CUDA_INJECTION64_PATH).
extern "C" int InitializeInjection() {
  const char* path = std::getenv("KTRACE_OUT");
  if (!path || !*path) {
    std::fprintf(stderr, "kernel_trace: KTRACE_OUT is not set; tracing nothing\n");
    return 1;
  }
  out = std::fopen(path, "w");
  if (!out) {
    std::fprintf(stderr, "kernel_trace: cannot write %s; tracing nothing\n", path);
    return 1;
  }
  report(cuptiActivityRegisterCallbacks(requested, completed), "registering the buffers");
  // kernels of graphs that the device launches, where this CUPTI has the switch (CUDA 12.3 on);
  // KTRACE_DEVICE_GRAPHS=0 leaves it off
  using DeviceGraph = CUptiResult (*)(uint8_t);
  const char* dg = std::getenv("KTRACE_DEVICE_GRAPHS");
  if (!(dg && std::string(dg) == "0"))
    if (auto f = reinterpret_cast<DeviceGraph>(
            dlsym(RTLD_DEFAULT, "cuptiActivityEnableDeviceGraph")))
      report(f(1), "tracing device-launched graphs");
  // CONCURRENT_KERNEL, not KERNEL: the latter makes kernels run one at a time
  report(cuptiActivityEnable(CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL), "tracing kernels");
  report(cuptiActivityEnable(CUPTI_ACTIVITY_KIND_MEMCPY), "tracing copies");
  report(cuptiActivityEnable(CUPTI_ACTIVITY_KIND_MEMSET), "tracing memsets");
  std::atexit(finish);
  return 1;
}
