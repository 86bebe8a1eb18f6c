#include "sim/gpu/data.h"

namespace bidex::sim::gpu {

namespace {

size_t align16(size_t n) { return (n + 15) & ~size_t(15); }

// Walks the fields of `nworld` worlds in table order, each 16-byte aligned: fills `d` with
// pointers into the block at `base` (when `base` is not null) and returns the block's bytes.
template <class T>
size_t place_fields(const Sizes& s, int nworld, std::byte* base, Data<T>* d) {
  d->nworld = nworld;
  size_t at = 0;
#define BIDEX_X(name, count, doc)                                            \
  d->name##_n = static_cast<long>(count);                                    \
  d->name = base ? reinterpret_cast<T*>(base + at) : nullptr;                \
  at += align16(sizeof(T) * static_cast<size_t>(d->name##_n) * nworld);
  BIDEX_GPU_REAL_FIELDS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc)                                            \
  d->name##_n = static_cast<long>(count);                                    \
  d->name = base ? reinterpret_cast<int*>(base + at) : nullptr;              \
  at += align16(sizeof(int) * static_cast<size_t>(d->name##_n) * nworld);
  BIDEX_GPU_INT_FIELDS(BIDEX_X)
#undef BIDEX_X
  return at;
}

}  // namespace

template <class T>
size_t layout_bytes(const Sizes& s, int nworld) {
  Data<T> d;
  return place_fields(s, nworld, nullptr, &d);
}

template <class T>
Data<T> layout(const Sizes& s, int nworld, std::byte* base) {
  Data<T> d;
  place_fields(s, nworld, base, &d);
  return d;
}

template <class T>
HostData<T>::HostData(const Sizes& s, int nworld)
    : block_((layout_bytes<T>(s, nworld) + sizeof(double) - 1) / sizeof(double), 0.0) {
  data_ = layout<T>(s, nworld, reinterpret_cast<std::byte*>(block_.data()));
}

template size_t layout_bytes<double>(const Sizes&, int);
template size_t layout_bytes<float>(const Sizes&, int);
template Data<double> layout<double>(const Sizes&, int, std::byte*);
template Data<float> layout<float>(const Sizes&, int, std::byte*);
template class HostData<double>;
template class HostData<float>;

}  // namespace bidex::sim::gpu
