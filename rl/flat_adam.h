// Adam over one flat buffer: every parameter's values are a view of one contiguous tensor, every
// gradient a view of another, and the moments are two more, so that a step, a gradient clip or
// a zero_grad is a handful of element-wise kernels whatever the number of parameter tensors
// (LibTorch's torch::optim::Adam launches its kernels once per tensor, and its clip_grad_norm_
// reads the norm back to the host). The learning rate lives on the device, so that a rule can
// change it there without a host synchronisation (PPO's KL-adaptive rate, rl/ppo.h).
//
// step() reads nothing from the host that changes between steps (the step count is a device
// tensor too), so a CUDA graph can capture it once and replay it (rl/ppo.h).
//
// The math is LibTorch's Adam without weight decay or amsgrad, and LibTorch's
// clip_grad_norm_ (2-norm):
//   m = b1 m + (1 - b1) g,  v = b2 v + (1 - b2) g^2,
//   p -= (lr / (1 - b1^t)) m / (sqrt(v) / sqrt(1 - b2^t) + eps)
// with one difference: a parameter whose gradient is undefined at a step counts as having a zero
// gradient (LibTorch's Adam skips it); the plain zero_grad() never undefines a gradient.
//
// Fused (`fused` true, where LibTorch has `_fused_adam_` with a device learning rate: 2.4 on;
// fused_available() says): the same math in one multi-tensor kernel that reads each value,
// gradient and moment once (the plain step is about ten element-wise passes over the buffers),
// with the gradient clip's factor applied inside it. zero_grad() then undefines the gradients, so
// that autograd hands its fresh gradient tensors over instead of adding them to zeroed ones;
// clip_grad_norm() and step() read them where autograd put them, and a gradient still undefined
// counts as zero. The bias corrections are computed in float32 there (float64 in the plain step):
// the two steps agree to float rounding (tests/rl/flat_adam_test.cc).
//
// Parameters must stay the tensors the optimiser was given. Something may still replace their
// storage behind its back: Module::load (InputArchive::read) calls tensor.set_(...), and a
// LibTorch 2 Module::zero_grad() undefines the gradients, so that autograd then allocates fresh
// ones. zero_grad(), clip_grad_norm() and step() therefore first compare, on the host, each
// parameter's and gradient's data pointer with its place in the flat buffers (cheap: no device
// work) and, where one has moved, copy its current values into the flat buffer and bind it
// again, so that the optimiser never updates a buffer the model no longer reads. A parameter
// whose shape, dtype or device changed is an error (build the optimiser after moving a model).
#pragma once

#include <cstdint>
#include <vector>

#include <torch/torch.h>

namespace bidex::rl {

class FlatAdam {
 public:
  // Each parameter's place in the flat buffers starts at a multiple of this many elements (the
  // gaps between places are zeros that the steps leave zero), so that every parameter, and its
  // place in a bfloat16 copy (keep_copy), is as aligned as a tensor of its own: a matrix product
  // on a GPU takes its fast kernels only from 16-byte aligned operands.
  static constexpr int64_t kAlign = 64;

  // `params`: distinct tensors of one dtype on one device (their values and gradients move
  // into the flat buffers here).
  // `fused`: the fused step where fused_available(), the plain one otherwise.
  FlatAdam(std::vector<torch::Tensor> params, double lr, double beta1 = 0.9,
           double beta2 = 0.999, double eps = 1e-8, bool fused = false);
  // whether this LibTorch has the fused step (2.4 on)
  static bool fused_available();
  // whether this optimiser steps fused
  bool fused() const { return fused_; }
  // a copy would share the buffers and step the parameters twice
  FlatAdam(const FlatAdam&) = delete;
  FlatAdam& operator=(const FlatAdam&) = delete;

  // Zeroes the flat gradient (one kernel); fused, undefines the gradients instead.
  void zero_grad();
  // Scales the gradients as torch::nn::utils::clip_grad_norm_ (2-norm) does: by
  // min(1, max_norm / (norm + 1e-6)), applied on the device (fused: by the next step(), which
  // leaves the scaled gradients in place). Returns the norm before clipping, a 0-dim tensor on the
  // device (nothing is read back).
  torch::Tensor clip_grad_norm(double max_norm);
  // One Adam step of every parameter.
  void step();

  // The learning rate: a 0-dim float64 tensor on the parameters' device, which step() reads;
  // write it in place to change the rate without a synchronisation.
  const torch::Tensor& lr_tensor() const { return lr_; }
  // Reads the rate back (a synchronisation: for statistics and checkpoints).
  double lr() const;
  void set_lr(double lr);
  // The steps taken (read from the device: a synchronisation).
  int64_t steps() const;

  // The moments, the step count and the learning rate. load() checks that the moments fit
  // these parameters (a c10::Error naming both sizes).
  //
  // load() also takes the state LibTorch's torch::optim::Adam saves (save()'s archive of an Adam
  // of one parameter group over the same parameters in the same order, as the learners'
  // checkpoints held before they moved to FlatAdam): each parameter's moments go to its place in
  // the flat buffers and its step count to the one count, which must then be the same for every
  // parameter (an Adam none of whose parameters has stepped loads as a fresh state). The rate
  // stays this optimiser's, as LibTorch's Adam::load keeps its options. An archive of neither
  // kind, or of other parameters, is a c10::Error saying so.
  void save(torch::serialize::OutputArchive& archive) const;
  void load(torch::serialize::InputArchive& archive);

  // Binds every parameter and gradient that no longer points into the flat buffers back to
  // them, keeping its current values. zero_grad(), clip_grad_norm() and step() call it; a CUDA
  // graph's replay of them runs no host code, so call it before replaying.
  void rebind();

  // A copy of the values in a lower type (bfloat16, for autocast's matrix products), kept equal
  // to the values cast to that type: made here, refreshed by every step() and by every rebind()
  // that moved a parameter. refresh_copy() refreshes it after the parameters were written in
  // place by anything else (a load into them, a test). One cast of the flat buffer: a matrix
  // product then reads its weight's place in the copy instead of casting the weight itself.
  void keep_copy(torch::ScalarType type);
  void refresh_copy();
  // Parameter p's place in the copy, shaped as p; undefined where there is no copy of `type`,
  // or p is not one of these parameters, or it no longer points into the flat buffer.
  torch::Tensor copy_of(const torch::Tensor& p, torch::ScalarType type) const;

  // While one lives, copy_of() of this optimiser is what weight_copy() finds on this thread
  // (the matrix products of rl/policy.h ask it for their weights). Scopes nest.
  class CopyScope {
   public:
    explicit CopyScope(const FlatAdam& opt);
    ~CopyScope();
    CopyScope(const CopyScope&) = delete;
    CopyScope& operator=(const CopyScope&) = delete;

   private:
    const FlatAdam* outer_;
  };
  // The innermost live scope's copy_of(p, type), or undefined where there is none.
  static torch::Tensor weight_copy(const torch::Tensor& p, torch::ScalarType type);

 private:
  // load() of a LibTorch Adam's archive
  void load_libtorch_adam(torch::serialize::InputArchive& archive);
  // a saved flat buffer without gaps (save()'s) into the places `views`
  static void scatter(const torch::Tensor& saved, const std::vector<torch::Tensor>& views);
  // fused: each parameter's gradient where autograd left it, or its zeroed flat view
  std::vector<torch::Tensor> current_grads() const;
  void fused_step();

  std::vector<torch::Tensor> params_;
  // each parameter's place in the flat buffers, shaped as the parameter
  std::vector<torch::Tensor> value_views_, grad_views_, exp_avg_views_, exp_avg_sq_views_;
  torch::Tensor values_, grads_, exp_avg_, exp_avg_sq_, lr_;
  torch::Tensor step_;  // 0-dim float64 on the device: nothing in step() is a host value
  double beta1_, beta2_, eps_;
  bool fused_;
  // fused: the step count and rate in float32, as the kernel reads them (copied from step_ and
  // lr_ at each step), and the pending clip's divisor (undefined: none)
  torch::Tensor step32_, lr32_, clip_divisor_;
  // keep_copy(): the values in a lower type, and each parameter's place in it
  torch::Tensor copy_;
  std::vector<torch::Tensor> copy_views_;
};

}  // namespace bidex::rl
