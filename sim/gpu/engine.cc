#include "sim/gpu/engine.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <type_traits>
#include <vector>

#include "sim/gpu/step.h"

namespace bidex::sim::gpu {

// A barrier that gives up loudly: lanes that stop meeting (a branch around sync() or a
// reduction that differs between lanes) would hang on the GPU; here they end the process with
// a message instead of hanging the test suite.
struct HostLaneGroup {
  explicit HostLaneGroup(int n) : n(n), slots(n, 0.0) {}
  void wait() {
    std::unique_lock<std::mutex> lock(mu);
    const long gen = generation;
    if (++count == n) {
      count = 0;
      ++generation;
      cv.notify_all();
      return;
    }
    if (!cv.wait_for(lock, std::chrono::seconds(30), [&] { return generation != gen; })) {
      std::fprintf(stderr, "GPU engine (host lanes): the %d lanes of a world stopped meeting at "
                           "barriers: a lane-dependent branch around sync() or a reduction\n", n);
      std::abort();
    }
  }
  int n;
  std::vector<double> slots;
  std::mutex mu;
  std::condition_variable cv;
  int count = 0;
  long generation = 0;
};

void host_lane_sync(HostLaneGroup* g) { g->wait(); }

double host_lane_reduce(HostLaneGroup* g, int id, double v, bool take_max) {
  g->slots[id] = v;
  g->wait();
  double r = g->slots[0];
  for (int i = 1; i < g->n; ++i) r = take_max ? std::max(r, g->slots[i]) : r + g->slots[i];
  g->wait();  // every lane has read the slots before they are reused
  return r;
}

template <class A, class B>
void copy_fields(const Data<A>& from, const Data<B>& to) {
#define BIDEX_X(name, count, doc)                                          \
  for (long i = 0; i < from.name##_n * from.nworld; ++i)                   \
    to.name[i] = static_cast<B>(from.name[i]);
  BIDEX_GPU_REAL_FIELDS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc) \
  for (long i = 0; i < from.name##_n * from.nworld; ++i) to.name[i] = from.name[i];
  BIDEX_GPU_INT_FIELDS(BIDEX_X)
#undef BIDEX_X
}

template <class T>
HostEngine<T>::HostEngine(const ModelArrays& arrays, int nworld, int lanes)
    : nworld_(nworld), lanes_(lanes), packed_(arrays), model_(packed_.host_view()),
      data_(arrays.s, nworld) {
  if (lanes < 1 || lanes > 32 || (lanes & (lanes - 1)))
    throw std::invalid_argument("HostEngine: lanes must be a power of two in 1..32");
  if constexpr (!std::is_same_v<T, double>)
    mirror_ = std::make_unique<HostData<double>>(arrays.s, nworld);
}

template <class T>
HostEngine<T>::~HostEngine() = default;

template <class T>
HostData<double>& HostEngine<T>::mirror() {
  if constexpr (std::is_same_v<T, double>)
    return data_;
  else
    return *mirror_;
}

template <class T>
void HostEngine<T>::upload() {
  if constexpr (!std::is_same_v<T, double>) copy_fields(mirror_->data(), data_.data());
}

template <class T>
void HostEngine<T>::download() {
  if constexpr (!std::is_same_v<T, double>) copy_fields(data_.data(), mirror_->data());
}

template <class T>
template <class F>
void HostEngine<T>::each_world(F fn) {
  for (int w = 0; w < nworld_; ++w) {
    if (lanes_ == 1) {
      fn(data_.world(w), Lanes{});
      continue;
    }
    HostLaneGroup group(lanes_);
    std::vector<std::thread> threads;
    for (int id = 0; id < lanes_; ++id)
      threads.emplace_back([&, id] { fn(data_.world(w), Lanes{id, lanes_, ~0u, &group}); });
    for (auto& t : threads) t.join();
  }
}

template <class T>
void HostEngine<T>::forward() {
  each_world([&](const World<T>& d, Lanes ln) { gpu::forward(model_, d, ln); });
}

template <class T>
void HostEngine<T>::step(int n) {
  each_world([&](const World<T>& d, Lanes ln) {
    for (int k = 0; k < n; ++k) gpu::step(model_, d, ln);
  });
}

template <class T>
std::string HostEngine<T>::describe() const {
  std::string s = std::is_same_v<T, double> ? "host float64" : "host float32";
  if (lanes_ > 1) s += ", " + std::to_string(lanes_) + " lanes per world (threads)";
  return s;
}

template class HostEngine<double>;
template class HostEngine<float>;
template void copy_fields(const Data<double>&, const Data<float>&);
template void copy_fields(const Data<float>&, const Data<double>&);
template void copy_fields(const Data<double>&, const Data<double>&);

}  // namespace bidex::sim::gpu
