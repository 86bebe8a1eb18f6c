#include "rl/policy.h"

#include <atomic>
#include <cmath>
#include <utility>

#include <ATen/core/dispatch/Dispatcher.h>

#include "rl/autocast.h"
#include "rl/flat_adam.h"

namespace bidex::rl {

RunningNormImpl::RunningNormImpl(int64_t dim, double clip, bool groups) : clip_(clip) {
  auto f64 = torch::TensorOptions().dtype(torch::kFloat64);
  mean_ = register_buffer("mean", torch::zeros({dim}, f64));
  var_ = register_buffer("var", torch::ones({dim}, f64));
  count_ = register_buffer("count", torch::full({groups ? dim : 1}, 1e-4, f64));
}

void merge_moments(torch::Tensor& count, torch::Tensor& mean, torch::Tensor& var,
                   const torch::Tensor& n, const torch::Tensor& bmean, const torch::Tensor& bvar) {
  const auto total = count + n;
  const auto seen = total > 0;
  const auto safe = torch::where(seen, total, torch::ones_like(total));
  const auto delta = bmean - mean;
  const auto m2 = var * count + bvar * n + delta.pow(2) * count * n / safe;
  mean.copy_(torch::where(seen, mean + delta * n / safe, mean));
  var.copy_(torch::where(seen, m2 / safe, var));
  count.copy_(total);
}

void RunningNormImpl::update(const torch::Tensor& x) {
  torch::NoGradGuard ng;
  auto xd = x.detach().to(torch::kFloat64).reshape({-1, mean_.size(0)});
  if (xd.size(0) == 0) return;
  merge_moments(count_, mean_, var_, torch::full_like(count_, double(xd.size(0))), xd.mean(0),
                xd.var(0, /*unbiased=*/false));
}

torch::Tensor RunningNormImpl::normalize(const torch::Tensor& x) const {
  auto m = mean_.to(x.scalar_type()), s = (var_ + 1e-8).sqrt().to(x.scalar_type());
  return ((x - m) / s).clamp(-clip_, clip_);
}

torch::Tensor RunningNormImpl::denormalize(const torch::Tensor& x) const {
  auto m = mean_.to(x.scalar_type()), s = (var_ + 1e-8).sqrt().to(x.scalar_type());
  return x * s + m;
}

namespace {
// A grouped normaliser's mean and standard deviation at groups of any shape, in `type`.
std::pair<torch::Tensor, torch::Tensor> moments_at(const torch::Tensor& mean,
                                                   const torch::Tensor& var,
                                                   const torch::Tensor& groups,
                                                   torch::ScalarType type) {
  auto at = [&](const torch::Tensor& v) {
    return v.index_select(0, groups.reshape({-1})).reshape(groups.sizes());
  };
  return {at(mean).to(type), (at(var) + 1e-8).sqrt().to(type)};
}
}  // namespace

void RunningNormImpl::update(const torch::Tensor& x, const torch::Tensor& groups) {
  if (!groups.defined()) return update(x.unsqueeze(-1));
  TORCH_CHECK(count_.size(0) == mean_.size(0), "RunningNorm: groups need a grouped normaliser");
  torch::NoGradGuard ng;
  // the population variance, as update(x)
  const auto m = group_moments(x.detach().to(torch::kFloat64), groups, mean_.size(0));
  merge_moments(count_, mean_, var_, m.count, m.mean, m.sq_dev / m.count.clamp_min(1));
}

GroupMoments group_moments(const torch::Tensor& x, const torch::Tensor& groups,
                           int64_t ngroups) {
  torch::NoGradGuard ng;
  const auto xf = x.reshape({-1});
  const auto g = groups.reshape({-1});
  const auto zeros = torch::zeros({ngroups}, xf.options());
  GroupMoments m;
  m.count = zeros.index_add(0, g, torch::ones_like(xf));
  m.mean = zeros.index_add(0, g, xf) / m.count.clamp_min(1);
  const auto dev = xf - m.mean.index_select(0, g);
  m.sq_dev = zeros.index_add(0, g, dev * dev);
  m.dev = dev.reshape(x.sizes());
  return m;
}

torch::Tensor RunningNormImpl::normalize(const torch::Tensor& x,
                                         const torch::Tensor& groups) const {
  if (!groups.defined()) return normalize(x.unsqueeze(-1)).squeeze(-1);
  const auto [m, s] = moments_at(mean_, var_, groups, x.scalar_type());
  return ((x - m) / s).clamp(-clip_, clip_);
}

torch::Tensor RunningNormImpl::denormalize(const torch::Tensor& x,
                                           const torch::Tensor& groups) const {
  if (!groups.defined()) return denormalize(x.unsqueeze(-1)).squeeze(-1);
  const auto [m, s] = moments_at(mean_, var_, groups, x.scalar_type());
  return x * s + m;
}

torch::Tensor gaussian_log_prob(const torch::Tensor& a, const torch::Tensor& mean,
                                const torch::Tensor& log_std) {
  auto z = (a - mean) * torch::exp(-log_std);
  return (-0.5 * z.pow(2) - log_std - 0.5 * std::log(2 * M_PI)).sum(-1);
}

torch::Tensor gaussian_entropy(const torch::Tensor& log_std) {
  return (log_std + 0.5 + 0.5 * std::log(2 * M_PI)).sum(-1);
}

torch::Tensor gaussian_kl(const torch::Tensor& mu_old, const torch::Tensor& log_std_old,
                          const torch::Tensor& mu_new, const torch::Tensor& log_std_new) {
  auto var_old = torch::exp(2 * log_std_old), var_new = torch::exp(2 * log_std_new);
  return (log_std_new - log_std_old + (var_old + (mu_old - mu_new).pow(2)) / (2 * var_new) - 0.5)
      .sum(-1);
}

namespace {
int64_t round_up(int64_t n, int64_t to) { return (n + to - 1) / to * to; }

// an initialised [in -> out] layer, padded when `align` asks for it
void push_linear(torch::nn::Sequential& net, int64_t in, int64_t out, double gain, int64_t align,
                 bool bias_grad_gemm) {
  torch::nn::Linear lin(in, out);
  torch::nn::init::orthogonal_(lin->weight, gain);
  torch::nn::init::zeros_(lin->bias);
  if (bias_grad_gemm || (align > 1 && (in % align != 0 || out % align != 0)))
    net->push_back(PaddedLinear(lin->weight, lin->bias, align, bias_grad_gemm));
  else
    net->push_back(lin);
}

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

// A parameter in the product's type: its place in the optimiser's copy where one is kept in that
// type (rl/flat_adam.h: one cast of all the weights per step instead of one per weight), else a
// cast of it.
torch::Tensor in_type(const torch::Tensor& p, torch::ScalarType type) {
  if (p.scalar_type() == type) return p;
  auto copy = FlatAdam::weight_copy(p, type);
  return copy.defined() ? copy : p.to(type);
}

// a.mm(b) in `type`: where the product's inputs are of a lower type on a CUDA device and this
// LibTorch has mm's out_dtype overload (2.8 on), the product writes float32 itself, from its
// float32 sums, instead of rounding them to the lower type and casting that (one kernel fewer,
// and no rounding); elsewhere, or where the overload refuses the call, the product and a cast.
torch::Tensor mm_to(const torch::Tensor& a, const torch::Tensor& b, torch::ScalarType type) {
  if (a.scalar_type() == type) return a.mm(b);
  static const auto op = c10::Dispatcher::singleton().findSchema({"aten::mm", "dtype"});
  static std::atomic<bool> usable = op.has_value();  // backward runs on autograd's threads
  if (usable && a.is_cuda() && type == torch::kFloat32) {
    try {
      return op->typed<at::Tensor(const at::Tensor&, const at::Tensor&, at::ScalarType)>().call(
          a, b, type);
    } catch (const c10::Error& e) {
      usable = false;  // another signature or no such kernel: never asked again
      TORCH_WARN("mm with an output type refused (", e.what_without_backtrace(),
                 "): bfloat16 gradients are rounded and cast from now on");
    }
  }
  return a.mm(b).to(type);
}

struct GemmBiasGradLinear : torch::autograd::Function<GemmBiasGradLinear> {
  static torch::Tensor forward(AutogradContext* ctx, const torch::Tensor& x,
                               const torch::Tensor& w, const torch::Tensor& b) {
    const auto type = Bf16Autocast::product_type(x.device().type(), x.scalar_type());
    const auto x2 = x.reshape({-1, x.size(-1)}).to(type);
    const auto wt = in_type(w, type), bt = in_type(b, type);
    auto y = torch::addmm(bt, x2, wt.t());
    ctx->save_for_backward({x2, wt});
    ctx->saved_data["x_grad"] = x.requires_grad();
    ctx->saved_data["x_type"] = static_cast<int64_t>(x.scalar_type());
    ctx->saved_data["w_type"] = static_cast<int64_t>(w.scalar_type());
    ctx->saved_data["b_type"] = static_cast<int64_t>(b.scalar_type());
    auto shape = x.sizes().vec();
    shape.back() = w.size(0);
    return y.view(shape);
  }

  static variable_list backward(AutogradContext* ctx, variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    const auto& x2 = saved[0];
    const auto& wt = saved[1];
    auto type_of = [&](const char* key) {
      return static_cast<torch::ScalarType>(ctx->saved_data[key].toInt());
    };
    const auto dy = grads[0].reshape({-1, wt.size(0)}).to(wt.scalar_type());
    torch::Tensor dx;
    if (ctx->saved_data["x_grad"].toBool()) {
      auto shape = grads[0].sizes().vec();
      shape.back() = wt.size(1);
      dx = dy.mm(wt).view(shape).to(type_of("x_type"));
    }
    const auto dw = mm_to(dy.t(), x2, type_of("w_type"));
    const auto ones = torch::ones({1, dy.size(0)}, dy.options());
    const auto db = mm_to(ones, dy, type_of("b_type")).view({wt.size(0)});
    return {dx, dw, db};
  }
};
}  // namespace

torch::Tensor linear_gemm_bias_grad(const torch::Tensor& x, const torch::Tensor& weight,
                                    const torch::Tensor& bias) {
  return GemmBiasGradLinear::apply(x, weight, bias);
}

PaddedLinearImpl::PaddedLinearImpl(const torch::Tensor& w, const torch::Tensor& b, int64_t align,
                                   bool bias_grad_gemm)
    : in_(w.size(1)), out_(w.size(0)), bias_grad_gemm_(bias_grad_gemm) {
  TORCH_CHECK(align >= 1, "PaddedLinear: align must be at least 1, got ", align);
  torch::NoGradGuard ng;
  const int64_t in_p = round_up(in_, align), out_p = round_up(out_, align);
  weight = register_parameter(
      "weight", torch::constant_pad_nd(w.detach(), {0, in_p - in_, 0, out_p - out_}));
  bias = register_parameter("bias", torch::constant_pad_nd(b.detach(), {0, out_p - out_}));
}

torch::Tensor PaddedLinearImpl::forward(const torch::Tensor& x) {
  const int64_t pad = weight.size(1) - x.size(-1);  // none where the caller padded already
  const auto xp = pad > 0 ? torch::constant_pad_nd(x, {0, pad}) : x;
  auto y = bias_grad_gemm_ ? linear_gemm_bias_grad(xp, weight, bias)
                           : torch::nn::functional::linear(xp, weight, bias);
  return weight.size(0) > out_ ? y.narrow(-1, 0, out_) : y;
}

torch::nn::Sequential mlp(int64_t in, const std::vector<int>& hidden, int64_t out,
                          const std::string& activation, double out_gain, int64_t align,
                          bool bias_grad_gemm) {
  torch::nn::Sequential net;
  int64_t width = in;
  for (int h : hidden) {
    push_linear(net, width, h, std::sqrt(2.0), align, bias_grad_gemm);
    if (activation == "elu") net->push_back(torch::nn::ELU());
    else if (activation == "relu") net->push_back(torch::nn::ReLU());
    else net->push_back(torch::nn::Tanh());
    width = h;
  }
  push_linear(net, width, out, out_gain, align, bias_grad_gemm);
  return net;
}

ActorCriticImpl::ActorCriticImpl(int64_t obs_dim, int64_t act_dim, const PpoConfig& c,
                                 int64_t value_tasks)
    : obs_dim_(obs_dim),
      act_dim_(act_dim),
      value_tasks_(value_tasks),
      use_obs_norm_(c.obs_norm),
      use_value_norm_(c.value_norm) {
  // orthogonal initialisation: sqrt(2) for hidden layers, 0.01 for the actor's output, 1 for the
  // critic's (the original's gains)
  const int64_t align = c.align_widths ? 8 : 1;
  actor_ = register_module(
      "actor", mlp(obs_dim, c.hidden, act_dim, c.activation, 0.01, align, c.bias_grad_gemm));
  critic_ = register_module(
      "critic", mlp(obs_dim, c.hidden, 1, c.activation, 1.0, align, c.bias_grad_gemm));
  log_std_ = register_parameter("log_std", torch::full({act_dim}, std::log(c.init_std)));
  obs_norm_ = register_module("obs_norm", RunningNorm(obs_dim));
  value_norm_ = register_module("value_norm", value_tasks > 0
                                                   ? RunningNorm(value_tasks, 1e9, true)
                                                   : RunningNorm(1, 1e9));
}

torch::Tensor ActorCriticImpl::normalize_obs(const torch::Tensor& obs) const {
  return use_obs_norm_ ? obs_norm_->normalize(obs) : obs;
}

torch::Tensor ActorCriticImpl::mean(const torch::Tensor& nobs) { return actor_->forward(nobs); }

std::vector<torch::Tensor> ActorCriticImpl::actor_parameters() const {
  auto p = actor_->parameters();
  p.push_back(log_std_);
  return p;
}

torch::Tensor ActorCriticImpl::raw_value(const torch::Tensor& nobs) {
  return critic_->forward(nobs).squeeze(-1);
}

torch::Tensor ActorCriticImpl::value_groups(const torch::Tensor& nobs) const {
  return value_tasks_ > 0 ? task_ids(nobs, value_tasks_) : torch::Tensor();
}

torch::Tensor ActorCriticImpl::value(const torch::Tensor& nobs) {
  auto v = raw_value(nobs).to(nobs.scalar_type());  // autocast's product back in the input's type
  return use_value_norm_ ? value_norm_->denormalize(v, value_groups(nobs)) : v;
}

QCriticImpl::QCriticImpl(int64_t obs_dim, int64_t act_dim, const std::vector<int>& hidden,
                         const std::string& activation, bool twin) {
  q1 = register_module("q1", mlp(obs_dim + act_dim, hidden, 1, activation, 1.0));
  if (twin) q2 = register_module("q2", mlp(obs_dim + act_dim, hidden, 1, activation, 1.0));
}

QCriticImpl::QCriticImpl(torch::nn::Sequential q1_net, torch::nn::Sequential q2_net) {
  q1 = register_module("q1", std::move(q1_net));
  if (q2_net) q2 = register_module("q2", std::move(q2_net));
}

torch::Tensor QCriticImpl::first(const torch::Tensor& obs, const torch::Tensor& actions) {
  return q1->forward(torch::cat({obs, actions}, 1)).squeeze(1);
}

std::pair<torch::Tensor, torch::Tensor> QCriticImpl::forward(const torch::Tensor& obs,
                                                             const torch::Tensor& actions) {
  const auto x = torch::cat({obs, actions}, 1);
  auto v1 = q1->forward(x).squeeze(1);
  return {v1, q2 ? q2->forward(x).squeeze(1) : v1};
}

void polyak_update(torch::nn::Module& src, torch::nn::Module& dst, double keep) {
  torch::NoGradGuard ng;
  auto s = src.parameters();
  auto d = dst.parameters();
  for (size_t i = 0; i < s.size(); ++i) d[i].mul_(keep).add_(s[i], 1.0 - keep);
}

void make_target(torch::nn::Module& src, torch::nn::Module& target) {
  polyak_update(src, target, 0.0);
  for (auto& p : target.parameters()) p.set_requires_grad(false);
}

torch::Tensor task_ids(const torch::Tensor& obs, int64_t ntasks) {
  return obs.narrow(-1, obs.size(-1) - ntasks, ntasks).argmax(-1);
}

}  // namespace bidex::rl
