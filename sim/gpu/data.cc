#include "sim/gpu/data.h"

namespace bidex::sim::gpu {

namespace {
size_t align16(size_t n) { return (n + 15) & ~size_t(15); }
}  // namespace

size_t world_bytes(const Sizes& s, size_t real_size) {
  size_t b = 0;
#define BIDEX_X(name, count, doc) b += real_size * static_cast<size_t>(count);
  BIDEX_GPU_REAL_FIELDS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc) b += sizeof(int) * static_cast<size_t>(count);
  BIDEX_GPU_INT_FIELDS(BIDEX_X)
#undef BIDEX_X
  return b;
}

// bytes of the block that layout() fills for `nworld` worlds
static size_t block_bytes(const Sizes& s, int nworld, size_t real_size) {
  size_t b = 0;
#define BIDEX_X(name, count, doc) b += align16(real_size * static_cast<size_t>(count) * nworld);
  BIDEX_GPU_REAL_FIELDS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc) b += align16(sizeof(int) * static_cast<size_t>(count) * nworld);
  BIDEX_GPU_INT_FIELDS(BIDEX_X)
#undef BIDEX_X
  return b;
}

template <class T>
size_t layout_bytes(const Sizes& s, int nworld) {
  return block_bytes(s, nworld, sizeof(T));
}

template <class T>
Data<T> layout(const Sizes& s, int nworld, std::byte* base) {
  Data<T> d;
  d.nworld = nworld;
  size_t at = 0;
#define BIDEX_X(name, count, doc)                                        \
  d.name##_n = static_cast<long>(count);                                 \
  d.name = reinterpret_cast<T*>(base + at);                              \
  at += align16(sizeof(T) * static_cast<size_t>(d.name##_n) * nworld);
  BIDEX_GPU_REAL_FIELDS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc)                                        \
  d.name##_n = static_cast<long>(count);                                 \
  d.name = reinterpret_cast<int*>(base + at);                            \
  at += align16(sizeof(int) * static_cast<size_t>(d.name##_n) * nworld);
  BIDEX_GPU_INT_FIELDS(BIDEX_X)
#undef BIDEX_X
  return d;
}

template <class T>
HostData<T>::HostData(const Sizes& s, int nworld)
    : block_((block_bytes(s, nworld, sizeof(T)) + sizeof(double) - 1) / sizeof(double), 0.0) {
  data_ = layout<T>(s, nworld, reinterpret_cast<std::byte*>(block_.data()));
}

template size_t layout_bytes<double>(const Sizes&, int);
template size_t layout_bytes<float>(const Sizes&, int);
template Data<double> layout<double>(const Sizes&, int, std::byte*);
template Data<float> layout<float>(const Sizes&, int, std::byte*);
template class HostData<double>;
template class HostData<float>;

}  // namespace bidex::sim::gpu
