#include "rl/trpo.h"

#include <cmath>

#include "rl/checkpoint.h"
#include "rl/flat_adam.h"
#include "rl/onpolicy.h"

namespace bidex::rl {

torch::Tensor conjugate_gradient(const std::function<torch::Tensor(const torch::Tensor&)>& Avp,
                                 const torch::Tensor& b, int iters, double tol) {
  // the product may need autograd (TRPO's Fisher-vector product): only its result is detached
  auto x = torch::zeros_like(b);
  auto r = b.detach().clone();
  auto p = r.clone();
  double rr = (r * r).sum().item<double>();
  for (int i = 0; i < iters && rr >= tol; ++i) {
    auto Ap = Avp(p).detach();
    const double alpha = rr / (p * Ap).sum().item<double>();
    x += alpha * p;
    r -= alpha * Ap;
    const double rr_new = (r * r).sum().item<double>();
    p = r + (rr_new / rr) * p;
    rr = rr_new;
  }
  return x;
}

LineSearch backtracking_line_search(const std::function<double(const torch::Tensor&)>& loss,
                                    const std::function<double(const torch::Tensor&)>& kl,
                                    const torch::Tensor& x0, const torch::Tensor& full_step,
                                    double expected, double max_kl, int backtracks,
                                    double accept_ratio) {
  const double loss0 = loss(x0);
  double fraction = 1.0;
  for (int k = 0; k < backtracks; ++k, fraction *= 0.5) {
    auto x = x0 + fraction * full_step;
    const double improvement = loss0 - loss(x);
    if (kl(x) <= max_kl && improvement > 0 && improvement > accept_ratio * fraction * expected)
      return {true, fraction, x, improvement};
  }
  return {false, 0.0, x0, 0.0};
}

namespace {

torch::Tensor flat(const std::vector<torch::Tensor>& ts) {
  std::vector<torch::Tensor> parts;
  for (auto& t : ts) parts.push_back(t.reshape({-1}));
  return torch::cat(parts);
}

void assign(const std::vector<torch::Tensor>& params, const torch::Tensor& x) {
  torch::NoGradGuard ng;
  int64_t at = 0;
  for (auto& p : params) {
    const int64_t n = p.numel();
    p.copy_(x.narrow(0, at, n).view_as(p));
    at += n;
  }
}

}  // namespace

NaturalStep natural_step(const std::vector<torch::Tensor>& params,
                         const std::function<torch::Tensor()>& surrogate,
                         const std::function<torch::Tensor()>& mean_kl,
                         const NaturalStepSettings& s) {
  NaturalStep out;
  const auto loss = surrogate();
  out.loss = loss.item<double>();
  const auto g = flat(torch::autograd::grad({loss}, params));
  auto fisher = [&](const torch::Tensor& v) {
    const auto kl = mean_kl();
    const auto dkl = flat(torch::autograd::grad({kl}, params, {}, true, true));
    const auto hv = flat(torch::autograd::grad({(dkl * v).sum()}, params));
    return hv + s.damping * v;
  };
  const auto x = conjugate_gradient(fisher, -g, s.cg_iters);
  const double shs = 0.5 * (x * fisher(x)).sum().item<double>();
  if (shs > 0 && std::isfinite(shs)) {
    const auto full_step = s.step_fraction * std::sqrt(s.max_kl / shs) * x;
    const double expected = -(g * full_step).sum().item<double>();
    const auto x0 = flat(params).detach();
    torch::NoGradGuard ng;
    auto loss_at = [&](const torch::Tensor& p) {
      assign(params, p);
      return surrogate().item<double>();
    };
    auto kl_at = [&](const torch::Tensor& p) {
      assign(params, p);
      return mean_kl().item<double>();
    };
    const LineSearch ls = backtracking_line_search(loss_at, kl_at, x0, full_step, expected,
                                                   s.max_kl, s.backtracks, s.accept_ratio);
    assign(params, ls.params);
    out.fraction = ls.fraction;
    out.kl = mean_kl().item<double>();
  }
  return out;
}

namespace {

class TrpoAlgorithm final : public GaussianOnPolicy {
 public:
  TrpoAlgorithm(const TrainConfig& config, int64_t D, int64_t A, int64_t N,
                const torch::Device& device)
      : GaussianOnPolicy(config.ppo, D, A, N, device) {
    const TrpoConfig& t = config.trpo;
    step_ = {t.max_kl, t.damping, t.cg_iters, t.backtracks, t.accept_ratio, t.step_fraction};
    // the model is on its device (GaussianOnPolicy): FlatAdam moves the critic's parameters
    // into its flat buffers (rl/flat_adam.h)
    critic_opt_ = std::make_unique<FlatAdam>(model_->critic_parameters(), c_.lr);
  }

  std::vector<double> update(const torch::Tensor& obs) override {
    const torch::Tensor last_value = finish_rollout(obs);
    const Rollout& r = *ro_;
    auto [adv, ret] = gae(r.rewards, r.values, r.dones, last_value, c_.gamma, c_.lambda);
    const int64_t B = r.horizon * r.nslot;
    const auto nobs = r.nobs.reshape({B, -1});
    const auto actions = r.actions.reshape({B, -1});
    const auto logp_old = r.logp.reshape({B});
    const auto mu_old = r.mu.reshape({B, -1});
    const auto log_std_old = r.log_std.detach();
    auto advantages = adv.reshape({B});
    advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8);

    // the policy: one natural-gradient step within the KL bound
    auto surrogate = [&] {  // to minimise
      auto logp = gaussian_log_prob(actions, model_->mean(nobs), model_->log_std());
      return -(torch::exp(logp - logp_old) * advantages).mean();
    };
    auto mean_kl = [&] {
      return gaussian_kl(mu_old, log_std_old, model_->mean(nobs), model_->log_std()).mean();
    };
    const NaturalStep step = natural_step(model_->actor_parameters(), surrogate, mean_kl, step_);
    const double policy_loss = step.loss, taken = step.fraction, kl_after = step.kl;

    // the critic: Adam on the returns
    torch::Tensor targets = ret.reshape({B});
    if (model_->uses_value_norm()) {
      model_->value_norm()->update(targets.unsqueeze(1));
      torch::NoGradGuard ng;
      targets = model_->value_norm()->normalize(targets.unsqueeze(1)).squeeze(1);
    }
    const int64_t mb = B / c_.minibatches;
    const auto on = torch::TensorOptions().device(nobs.device());
    auto value_sum = torch::zeros({}, on.dtype(torch::kFloat64));
    int n = 0;
    for (int epoch = 0; epoch < c_.epochs; ++epoch) {
      auto perm = torch::randperm(B, on.dtype(torch::kLong));
      for (int k = 0; k < c_.minibatches; ++k) {
        auto idx = perm.narrow(0, k * mb, mb);
        auto value_loss = (model_->raw_value(nobs.index_select(0, idx)) -
                           targets.index_select(0, idx)).pow(2).mean();
        // the value loss reaches every parameter of the critic: no gradient is undefined at a
        // step (FlatAdam would step it as zero where LibTorch's Adam skipped it)
        critic_opt_->zero_grad();
        (c_.value_coef * value_loss).backward();
        critic_opt_->clip_grad_norm(c_.max_grad_norm);
        critic_opt_->step();
        value_sum += value_loss.detach().to(torch::kFloat64);
        ++n;
      }
    }
    const double entropy = gaussian_entropy(model_->log_std()).item<double>();
    return {policy_loss, (value_sum / std::max(n, 1)).item<double>(), entropy, kl_after, taken,
            action_std()};
  }

  const std::vector<std::string>& metric_names() const override {
    static const std::vector<std::string> names = {"policy_loss", "value_loss", "entropy",
                                                   "kl",          "step_fraction", "action_std"};
    return names;
  }

  void save(torch::serialize::OutputArchive& root) override {
    write_part(root, "model", *model_);
    write_part(root, "critic_optimizer", *critic_opt_);
  }

  void load(torch::serialize::InputArchive& root, const std::string& path) override {
    read_checked(path, "does not fit this run's networks", [&] {
      read_module(root, "model", *model_, path, "this run's networks");
      read_optimizer(root, "critic_optimizer", *critic_opt_);
    });
  }

 private:
  NaturalStepSettings step_;
  std::unique_ptr<FlatAdam> critic_opt_;
};

}  // namespace

std::unique_ptr<Algorithm> make_trpo(const TrainConfig& config, int64_t obs_dim, int64_t act_dim,
                                     int64_t nslot, const torch::Device& device) {
  return std::make_unique<TrpoAlgorithm>(config, obs_dim, act_dim, nslot, device);
}

}  // namespace bidex::rl
