#include "rl/flat_adam.h"

#include <cmath>

#include <torch/version.h>

// LibTorch 2.4 has _fused_adam_ with a learning rate tensor on the CPU and on CUDA devices
#if TORCH_VERSION_MAJOR > 2 || (TORCH_VERSION_MAJOR == 2 && TORCH_VERSION_MINOR >= 4)
#define BIDEX_FUSED_ADAM 1
#else
#define BIDEX_FUSED_ADAM 0
#endif

namespace bidex::rl {

namespace {

// A parameter (or gradient) found on other storage must still fit its place in the flat buffer.
void check_fits(const torch::Tensor& now, const torch::Tensor& place, size_t k, const char* what) {
  TORCH_CHECK(now.sizes() == place.sizes() && now.dtype() == place.dtype() &&
                  now.device() == place.device(),
              "FlatAdam: the ", what, " of parameter ", k, " is now ", now.sizes(), " ",
              now.dtype(), " on ", now.device(), ", the optimiser holds ", place.sizes(), " ",
              place.dtype(), " on ", place.device());
}

// a parameter's place: from the next multiple of kAlign elements
int64_t round_up(int64_t n) {
  return (n + FlatAdam::kAlign - 1) / FlatAdam::kAlign * FlatAdam::kAlign;
}

// the parameters' places of a flat buffer, one after the other without the gaps (as saved)
torch::Tensor compact(const std::vector<torch::Tensor>& views) {
  std::vector<torch::Tensor> rows;
  for (const auto& v : views) rows.push_back(v.reshape({-1}));
  return torch::cat(rows);
}

}  // namespace

bool FlatAdam::fused_available() { return BIDEX_FUSED_ADAM != 0; }

FlatAdam::FlatAdam(std::vector<torch::Tensor> params, double lr, double beta1, double beta2,
                   double eps, bool fused)
    : params_(std::move(params)),
      beta1_(beta1),
      beta2_(beta2),
      eps_(eps),
      fused_(fused && fused_available()) {
  TORCH_CHECK(!params_.empty(), "FlatAdam: no parameters to optimise");
  const auto& first = params_[0];
  int64_t total = 0;
  for (size_t k = 0; k < params_.size(); ++k) {
    const auto& p = params_[k];
    TORCH_CHECK(p.dtype() == first.dtype() && p.device() == first.device(), "FlatAdam: parameter ",
                k, " is ", p.dtype(), " on ", p.device(), ", parameter 0 ", first.dtype(), " on ",
                first.device(), " (one flat buffer holds them all)");
    // a second binding of the same tensor would pull it away from the first place every call
    for (size_t j = 0; j < k; ++j)
      TORCH_CHECK(!p.is_same(params_[j]), "FlatAdam: parameter ", k, " is parameter ", j,
                  " again");
    total += round_up(p.numel());
  }
  const auto opts = torch::TensorOptions().dtype(first.dtype()).device(first.device());
  values_ = torch::zeros({total}, opts);
  grads_ = torch::zeros({total}, opts);
  exp_avg_ = torch::zeros({total}, opts);
  exp_avg_sq_ = torch::zeros({total}, opts);
  lr_ = torch::scalar_tensor(lr, opts.dtype(torch::kFloat64));
  step_ = torch::zeros({}, opts.dtype(torch::kFloat64));
  step32_ = torch::zeros({}, opts.dtype(torch::kFloat32));
  lr32_ = torch::zeros({}, opts.dtype(torch::kFloat32));
  int64_t at = 0;
  for (const auto& p : params_) {
    auto view = [&](const torch::Tensor& flat) { return flat.narrow(0, at, p.numel()).view(p.sizes()); };
    value_views_.push_back(view(values_));
    grad_views_.push_back(view(grads_));
    exp_avg_views_.push_back(view(exp_avg_));
    exp_avg_sq_views_.push_back(view(exp_avg_sq_));
    at += round_up(p.numel());
  }
  // nothing points into the new buffers yet: this moves every value and gradient in
  rebind();
}

void FlatAdam::rebind() {
  torch::NoGradGuard ng;
  bool moved = false;
  for (size_t k = 0; k < params_.size(); ++k) {
    auto& p = params_[k];
    const auto& values = value_views_[k];
    if (p.data_ptr() != values.data_ptr()) {
      check_fits(p, values, k, "values");
      values.copy_(p.detach());
      p.set_data(values);
      moved = true;
    }
    if (fused_) continue;  // its gradients stay where autograd puts them
    // autograd accumulates into a defined gradient in place, so a bound one stays bound
    auto& g = p.mutable_grad();
    const auto& grad = grad_views_[k];
    if (!g.defined()) {
      grad.zero_();
      g = grad;
    } else if (g.data_ptr() != grad.data_ptr()) {
      check_fits(g, grad, k, "gradient");
      grad.copy_(g);
      g = grad;
    }
  }
  if (moved) refresh_copy();
}

void FlatAdam::keep_copy(torch::ScalarType type) {
  if (copy_.defined() && copy_.scalar_type() == type) return;
  copy_ = torch::empty(values_.sizes(), values_.options().dtype(type));
  copy_views_.clear();
  for (const auto& v : value_views_)
    copy_views_.push_back(
        copy_.narrow(0, v.storage_offset() - values_.storage_offset(), v.numel()).view(v.sizes()));
  refresh_copy();
}

void FlatAdam::refresh_copy() {
  torch::NoGradGuard ng;
  if (copy_.defined()) copy_.copy_(values_);
}

torch::Tensor FlatAdam::copy_of(const torch::Tensor& p, torch::ScalarType type) const {
  if (!copy_.defined() || copy_.scalar_type() != type) return {};
  for (size_t k = 0; k < params_.size(); ++k)
    if (p.is_same(params_[k]))
      return p.data_ptr() == value_views_[k].data_ptr() ? copy_views_[k] : torch::Tensor();
  return {};
}

namespace {
thread_local const FlatAdam* active_copies = nullptr;
}  // namespace

FlatAdam::CopyScope::CopyScope(const FlatAdam& opt) : outer_(active_copies) {
  active_copies = &opt;
}

FlatAdam::CopyScope::~CopyScope() { active_copies = outer_; }

torch::Tensor FlatAdam::weight_copy(const torch::Tensor& p, torch::ScalarType type) {
  return active_copies ? active_copies->copy_of(p, type) : torch::Tensor();
}

void FlatAdam::zero_grad() {
  rebind();
  clip_divisor_ = torch::Tensor();
  if (!fused_) {
    grads_.zero_();
    return;
  }
  for (auto& p : params_) p.mutable_grad() = torch::Tensor();
}

std::vector<torch::Tensor> FlatAdam::current_grads() const {
  std::vector<torch::Tensor> g;
  g.reserve(params_.size());
  for (size_t k = 0; k < params_.size(); ++k) {
    const auto& grad = params_[k].grad();
    if (!grad.defined()) {
      g.push_back(grad_views_[k]);  // never written when fused: zeros
      continue;
    }
    check_fits(grad, grad_views_[k], k, "gradient");
    g.push_back(grad);
  }
  return g;
}

torch::Tensor FlatAdam::clip_grad_norm(double max_norm) {
  rebind();
  torch::NoGradGuard ng;
  if (fused_) {  // the norm of the tensors' norms; step() divides by the clip's divisor
    const auto norm = torch::stack(torch::_foreach_norm(current_grads())).norm();
    clip_divisor_ = torch::clamp_min((norm + 1e-6) / max_norm, 1.0).to(torch::kFloat32);
    return norm;
  }
  auto norm = grads_.norm();
  grads_.mul_(torch::clamp_max(max_norm / (norm + 1e-6), 1.0));
  return norm;
}

void FlatAdam::fused_step() {
#if BIDEX_FUSED_ADAM
  step32_.copy_(step_);
  lr32_.copy_(lr_);
  const std::vector<torch::Tensor> steps(params_.size(), step32_);
  const std::optional<torch::Tensor> divisor =
      clip_divisor_.defined() ? std::optional<torch::Tensor>(clip_divisor_) : std::nullopt;
  at::_fused_adam_(value_views_, current_grads(), exp_avg_views_, exp_avg_sq_views_,
                   at::TensorList(), steps, lr32_, beta1_, beta2_, /*weight_decay=*/0.0, eps_,
                   /*amsgrad=*/false, /*maximize=*/false, divisor, std::nullopt);
  clip_divisor_ = torch::Tensor();
#else
  TORCH_CHECK(false, "FlatAdam: this LibTorch has no fused step (fused_available() is false)");
#endif
}

void FlatAdam::step() {
  rebind();
  torch::NoGradGuard ng;
  // the step count and the bias corrections on the device (float64, as LibTorch's Adam computes
  // them on the host), so that a CUDA graph replaying this step counts on
  step_.add_(1);
  if (fused_) {
    fused_step();
    refresh_copy();
    return;
  }
  const auto bias_correction1 = 1 - torch::pow(beta1_, step_);
  const auto bias_correction2 = 1 - torch::pow(beta2_, step_);
  exp_avg_.mul_(beta1_).add_(grads_, 1 - beta1_);
  exp_avg_sq_.mul_(beta2_).addcmul_(grads_, grads_, 1 - beta2_);
  const auto denom = (exp_avg_sq_.sqrt() / bias_correction2.sqrt()).add_(eps_);
  // addcdiv_ takes its factor from the host only: divide, scale by the device's rate, subtract
  values_.sub_((exp_avg_ / denom).mul_(lr_ / bias_correction1));
  refresh_copy();
}

double FlatAdam::lr() const { return lr_.item<double>(); }

int64_t FlatAdam::steps() const { return static_cast<int64_t>(step_.item<double>()); }

void FlatAdam::set_lr(double lr) { lr_.fill_(lr); }

void FlatAdam::save(torch::serialize::OutputArchive& archive) const {
  // without the gaps between the places: the same archive as before the places were aligned
  archive.write("exp_avg", compact(exp_avg_views_));
  archive.write("exp_avg_sq", compact(exp_avg_sq_views_));
  archive.write("step", step_);
  archive.write("lr", lr_);
}

void FlatAdam::load(torch::serialize::InputArchive& archive) {
  torch::Tensor exp_avg, exp_avg_sq, step, lr;
  if (!archive.try_read("exp_avg", exp_avg)) {
    load_libtorch_adam(archive);
    return;
  }
  archive.read("exp_avg_sq", exp_avg_sq);
  archive.read("step", step);
  archive.read("lr", lr);
  int64_t total = 0;
  for (const auto& v : value_views_) total += v.numel();
  const std::vector<int64_t> want{total};
  TORCH_CHECK(exp_avg.sizes() == want && exp_avg_sq.sizes() == want,
              "FlatAdam: the saved moments have shapes ", exp_avg.sizes(), " and ",
              exp_avg_sq.sizes(), ", these parameters ", torch::IntArrayRef(want));
  TORCH_CHECK(step.numel() == 1 && lr.numel() == 1, "FlatAdam: the saved step and rate have ",
              step.numel(), " and ", lr.numel(), " values, expected 1 each");
  torch::NoGradGuard ng;
  scatter(exp_avg, exp_avg_views_);
  scatter(exp_avg_sq, exp_avg_sq_views_);
  lr_.fill_(lr.item<double>());
  step_.fill_(step.item<double>());
}

void FlatAdam::scatter(const torch::Tensor& saved, const std::vector<torch::Tensor>& views) {
  int64_t at = 0;
  for (const auto& v : views) {
    v.copy_(saved.narrow(0, at, v.numel()).view(v.sizes()));
    at += v.numel();
  }
}

void FlatAdam::load_libtorch_adam(torch::serialize::InputArchive& archive) {
  // torch/optim/serialize.h: "pytorch_version", "state" (one archive per parameter that has
  // stepped, named by the address its tensor had) and "param_groups" (each group's parameters
  // as those names, in the optimiser's order)
  c10::IValue version;
  torch::serialize::InputArchive state, groups, group;
  TORCH_CHECK(archive.try_read("pytorch_version", version) && archive.try_read("state", state) &&
                  archive.try_read("param_groups", groups),
              "FlatAdam: the saved optimiser state is neither FlatAdam's (exp_avg, exp_avg_sq, "
              "step, lr) nor LibTorch Adam's (pytorch_version, state, param_groups)");
  torch::Tensor ngroups, nparams;
  groups.read("param_groups/size", ngroups);
  TORCH_CHECK(ngroups.item<int64_t>() == 1, "FlatAdam: the saved LibTorch Adam state has ",
              ngroups.item<int64_t>(), " parameter groups, FlatAdam one");
  groups.read("param_groups/0", group);
  group.read("params/size", nparams);
  const auto n = static_cast<size_t>(nparams.item<int64_t>());
  TORCH_CHECK(n == params_.size(), "FlatAdam: the saved LibTorch Adam state is of ", n,
              " parameters, this optimiser's of ", params_.size());
  std::vector<torch::Tensor> avg(n), avg_sq(n);
  int64_t steps = 0;
  size_t stepped = 0;
  for (size_t k = 0; k < n; ++k) {
    c10::IValue name;
    group.read("params/" + std::to_string(k), name);
    torch::serialize::InputArchive s;
    if (!state.try_read(name.toStringRef(), s)) continue;  // never stepped
    c10::IValue step;
    s.read("step", step);
    s.read("exp_avg", avg[k]);
    s.read("exp_avg_sq", avg_sq[k]);
    const auto& place = value_views_[k];
    TORCH_CHECK(avg[k].sizes() == place.sizes() && avg_sq[k].sizes() == place.sizes(),
                "FlatAdam: the saved LibTorch Adam moments of parameter ", k, " have shapes ",
                avg[k].sizes(), " and ", avg_sq[k].sizes(), ", the parameter ", place.sizes());
    TORCH_CHECK(stepped == 0 || step.toInt() == steps, "FlatAdam: in the saved LibTorch Adam state",
                " parameter ", k, " took ", step.toInt(), " steps, an earlier one ", steps,
                " (FlatAdam counts one for all)");
    steps = step.toInt();
    ++stepped;
  }
  TORCH_CHECK(stepped == 0 || stepped == n, "FlatAdam: the saved LibTorch Adam state has moments",
              " of ", stepped, " of its ", n, " parameters (FlatAdam steps them all together)");
  torch::NoGradGuard ng;
  if (stepped == 0) {
    exp_avg_.zero_();
    exp_avg_sq_.zero_();
  } else {
    for (size_t k = 0; k < n; ++k) {
      exp_avg_views_[k].copy_(avg[k]);
      exp_avg_sq_views_[k].copy_(avg_sq[k]);
    }
  }
  step_.fill_(static_cast<double>(steps));
}

}  // namespace bidex::rl
