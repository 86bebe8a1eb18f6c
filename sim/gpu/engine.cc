#include "sim/gpu/engine.h"

#include <type_traits>

#include "sim/gpu/step.h"

namespace bidex::sim::gpu {

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
HostEngine<T>::HostEngine(const ModelArrays& arrays, int nworld)
    : nworld_(nworld), packed_(arrays), model_(packed_.host_view()), data_(arrays.s, nworld) {
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
void HostEngine<T>::forward() {
  for (int w = 0; w < nworld_; ++w) gpu::forward(model_, data_.world(w), Lanes{});
}

template <class T>
void HostEngine<T>::step(int n) {
  for (int w = 0; w < nworld_; ++w)
    for (int k = 0; k < n; ++k) gpu::step(model_, data_.world(w), Lanes{});
}

template <class T>
std::string HostEngine<T>::describe() const {
  return std::is_same_v<T, double> ? "host float64" : "host float32";
}

template class HostEngine<double>;
template class HostEngine<float>;
template void copy_fields(const Data<double>&, const Data<float>&);
template void copy_fields(const Data<float>&, const Data<double>&);
template void copy_fields(const Data<double>&, const Data<double>&);

}  // namespace bidex::sim::gpu
