#pragma once
// A scope in which the network products on one device type run in bfloat16 (LibTorch's
// autocast): matrix products take bfloat16 copies of their inputs and weights, while the
// parameters, their gradients and the optimizer stay float32. The casts are not cached, so a
// CUDA graph captured inside the scope replays the casts of the weights as they are then.
// LibTorch 2.4 renamed the per-device calls; both spellings are handled here.

#include <ATen/autocast_mode.h>
#include <torch/version.h>

namespace bidex::rl {

class Bf16Autocast {
 public:
  // on = false: does nothing (the caller's setting decides)
  Bf16Autocast(c10::DeviceType device, bool on) : device_(device), on_(on) {
    if (!on_) return;
    was_enabled_ = enabled(device_);
    was_dtype_ = dtype(device_);
    was_cache_ = at::autocast::is_autocast_cache_enabled();
    set(device_, true, at::kBFloat16);
    at::autocast::set_autocast_cache_enabled(false);
    at::autocast::increment_nesting();
  }
  ~Bf16Autocast() {
    if (!on_) return;
    if (at::autocast::decrement_nesting() == 0) at::autocast::clear_cache();
    set(device_, was_enabled_, was_dtype_);
    at::autocast::set_autocast_cache_enabled(was_cache_);
  }
  Bf16Autocast(const Bf16Autocast&) = delete;
  Bf16Autocast& operator=(const Bf16Autocast&) = delete;

  // the type a matrix product on `device` runs in now: autocast's where it is on, else `type`
  static at::ScalarType product_type(c10::DeviceType device, at::ScalarType type) {
    return enabled(device) ? dtype(device) : type;
  }

 private:
#if TORCH_VERSION_MAJOR > 2 || (TORCH_VERSION_MAJOR == 2 && TORCH_VERSION_MINOR >= 4)
  static bool enabled(c10::DeviceType d) { return at::autocast::is_autocast_enabled(d); }
  static at::ScalarType dtype(c10::DeviceType d) { return at::autocast::get_autocast_dtype(d); }
  static void set(c10::DeviceType d, bool on, at::ScalarType t) {
    at::autocast::set_autocast_enabled(d, on);
    at::autocast::set_autocast_dtype(d, t);
  }
#else
  static bool cuda(c10::DeviceType d) { return d == c10::DeviceType::CUDA; }
  static bool enabled(c10::DeviceType d) {
    return cuda(d) ? at::autocast::is_enabled() : at::autocast::is_cpu_enabled();
  }
  static at::ScalarType dtype(c10::DeviceType d) {
    return cuda(d) ? at::autocast::get_autocast_gpu_dtype()
                   : at::autocast::get_autocast_cpu_dtype();
  }
  static void set(c10::DeviceType d, bool on, at::ScalarType t) {
    if (cuda(d)) {
      at::autocast::set_enabled(on);
      at::autocast::set_autocast_gpu_dtype(t);
    } else {
      at::autocast::set_cpu_enabled(on);
      at::autocast::set_autocast_cpu_dtype(t);
    }
  }
#endif

  c10::DeviceType device_;
  bool on_;
  bool was_enabled_ = false;
  at::ScalarType was_dtype_ = at::kFloat;
  bool was_cache_ = true;
};

}  // namespace bidex::rl
