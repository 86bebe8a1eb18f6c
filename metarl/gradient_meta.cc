// MAML and ProMP on the learning core. One meta-update: `horizon` steps of every slot with the
// meta-policy theta (the pre-adaptation rollouts), one adaptation per task from its slots' rows
// (MAML: the policy-gradient step, maml.h; ProMP: the LVC step, promp.h), `horizon` steps of
// every slot with its task's adapted policy (the post-adaptation rollouts), then `epochs` outer
// steps: each adapts theta again, differentiably, and minimises the mean over tasks of the
// clipped surrogate of the adapted policy on its rollouts (ProMP adds its KL penalty on the
// pre-adaptation rows). A critic, fitted to both phases' returns, gives GAE advantages.
// Episodes run on across the phase boundary; time-limited ones are bootstrapped. Optionally
// (config.h) both networks read normalised observations, each task's rewards are scaled by
// its return std (task_scale.h), and the inner step sizes are learned per parameter (Meta-SGD).
#include <cmath>

#include "metarl/algorithms.h"
#include "metarl/config.h"
#include "metarl/functional_policy.h"
#include "metarl/maml.h"
#include "metarl/promp.h"
#include "metarl/task_scale.h"
#include "rl/checkpoint.h"
#include "rl/policy.h"
#include "rl/ppo.h"

namespace bidex::metarl {

namespace {

// The meta-parameters as a module: Adam steps them and checkpoints hold them.
struct ParamsImpl : torch::nn::Module {
  explicit ParamsImpl(const std::vector<torch::Tensor>& init) {
    for (size_t i = 0; i < init.size(); ++i) {
      std::string name = "p";  // built with append: GCC 12 -O3 misfires on "p" + std::string
      name.append(std::to_string(i));
      list.push_back(register_parameter(name, init[i].detach().clone()));
    }
  }
  std::vector<torch::Tensor> list;
};
TORCH_MODULE(Params);

// Rows [T, N, ...] of the slots in `idx`, flattened to [T x |idx|, ...].
torch::Tensor rows(const torch::Tensor& x, const torch::Tensor& idx) {
  auto r = x.index_select(1, idx);
  std::vector<int64_t> shape = {-1};
  for (int64_t d = 2; d < r.dim(); ++d) shape.push_back(r.size(d));
  return r.reshape(shape);
}

torch::Tensor normalised(const torch::Tensor& a) {
  return a.numel() > 1 ? (a - a.mean()) / (a.std() + 1e-8) : a - a.mean();
}

// One task's rows of a rollout [T, N, ...]: the slots in `idx`, only the rows where `mask`
// ([T x |idx|] bool) holds when it is given, the advantages normalised over them.
Batch task_batch(const torch::Tensor& obs, const torch::Tensor& actions,
                 const torch::Tensor& adv, const torch::Tensor& logp, const torch::Tensor& idx,
                 const torch::Tensor& mask = {}) {
  auto pick = [&](const torch::Tensor& x) {
    auto r = rows(x, idx);
    return mask.defined() ? r.index({mask}) : r;
  };
  return {pick(obs), pick(actions), normalised(pick(adv)), pick(logp)};
}

// One phase's rollout, [T, N, ...]: rewards as learned from (task_reward_norm's scale, the
// time-limit bootstraps), paid as the tasks paid them (the metrics).
struct Phase {
  torch::Tensor obs, actions, logp, values, rewards, paid, dones;
  void allocate(int64_t T, int64_t N, int64_t D, int64_t A, const torch::TensorOptions& f) {
    obs = torch::zeros({T, N, D}, f);
    actions = torch::zeros({T, N, A}, f);
    logp = torch::zeros({T, N}, f);
    values = torch::zeros({T, N}, f);
    rewards = torch::zeros({T, N}, f);
    paid = torch::zeros({T, N}, f);
    dones = torch::zeros({T, N}, f);
  }
};

class GradientMeta final : public rl::Algorithm, public rl::Adaptive {
 public:
  GradientMeta(const GradientMetaConfig& c, bool promp, int64_t D, int64_t A, int64_t N,
               uint64_t seed, const torch::Device& device)
      : c_(c), promp_(promp), device_(device) {
    pi_ = FunctionalGaussian::init(D, c.hidden, A, c.activation, c.init_std, seed);
    params_ = Params(pi_.params);
    pi_.params.clear();  // params_ holds them
    critic_ = rl::mlp(D, c.hidden, 1, c.activation, 1.0);
    params_->to(device);
    critic_->to(device);
    if (c.input_norm) {
      obs_norm_ = rl::RunningNorm(D);
      obs_norm_->to(device);
    }
    std::vector<torch::Tensor> all = params_->parameters();
    for (auto& p : critic_->parameters()) all.push_back(p);
    if (c.learn_inner_lr) {  // Meta-SGD: a step size per element, inner_lr to start with
      std::vector<torch::Tensor> init;
      for (auto& p : theta()) init.push_back(torch::zeros_like(p));  // log(alpha / inner_lr)
      alphas_ = Params(init);
      alphas_->to(device);
      for (auto& p : alphas_->parameters()) all.push_back(p);
    }
    opt_ = std::make_unique<torch::optim::Adam>(all, torch::optim::AdamOptions(c.lr));
    eta_ = torch::full({1}, c.init_kl_coef, torch::kFloat64);
    const auto f = torch::TensorOptions().dtype(torch::kFloat32).device(device);
    if (N > 0) {
      pre_.allocate(c.horizon, N, D, A, f);
      post_.allocate(c.horizon, N, D, A, f);
      if (c.task_reward_norm) scale_ = std::make_unique<TaskReturnScale>(N, c.gamma, device);
      set_slot_tasks(std::vector<int>(N, 0), 1);
    }
  }

  int steps_per_update() const override { return 2 * c_.horizon; }

  void set_slot_tasks(const std::vector<int>& slot_task, int ntasks) override {
    task_rows_ = group_slots(slot_task, ntasks);
    if (scale_) scale_->set_slot_tasks(slot_task, ntasks);
  }

  torch::Tensor act(const torch::Tensor& raw_obs) override {
    torch::NoGradGuard ng;
    if (obs_norm_) obs_norm_->update(raw_obs);
    const auto obs = in(raw_obs);
    const bool pre = t_ < c_.horizon;
    if (t_ == c_.horizon) adapted_ = adapt_from_pre(obs);
    Phase& ph = pre ? pre_ : post_;
    const int64_t k = pre ? t_ : t_ - c_.horizon;
    torch::Tensor mean, log_std;
    if (pre) {
      mean = pi_.mean(theta(), obs);
      log_std = pi_.log_std(theta()).expand_as(mean);
    } else {
      std::tie(mean, log_std) = per_task(adapted_, task_rows_, obs);
    }
    const auto a = mean + log_std.exp() * torch::randn_like(mean);
    ph.obs[k] = obs;
    ph.actions[k] = a;
    ph.logp[k] = rl::gaussian_log_prob(a, mean, log_std);
    ph.values[k] = critic_->forward(obs).squeeze(-1);
    return a;
  }

  void observe(const rl::Transition& t) override {
    torch::NoGradGuard ng;
    Phase& ph = t_ < c_.horizon ? pre_ : post_;
    const int64_t k = t_ < c_.horizon ? t_ : t_ - c_.horizon;
    ph.rewards[k] = (scale_ ? scale_->scaled(t.reward, t.done) : t.reward) + bootstrap(t);
    ph.paid[k] = t.reward;
    ph.dones[k] = t.done;
    ++t_;
  }

  std::vector<double> update(const torch::Tensor& obs) override {
    torch::AutoGradMode grad_on(true);
    torch::Tensor post_adv, post_ret;
    {
      torch::NoGradGuard ng;
      const auto last = critic_->forward(in(obs)).squeeze(-1);
      std::tie(post_adv, post_ret) =
          rl::gae(post_.rewards, post_.values, post_.dones, last, c_.gamma, c_.lambda);
    }
    const std::vector<torch::Tensor> theta_old = detached(theta());
    const int K = static_cast<int>(task_rows_.size());
    const std::vector<Batch>& pre_b = pre_batches_;  // the adaptation's rows (adapt_from_pre)
    std::vector<Batch> post_b;
    for (const auto& idx : task_rows_)
      post_b.push_back(task_batch(post_.obs, post_.actions, post_adv, post_.logp, idx));
    const auto all_obs = torch::cat({pre_.obs.flatten(0, 1), post_.obs.flatten(0, 1)});
    const auto all_ret = torch::cat({pre_ret_.flatten(), post_ret.flatten()});
    const double eta = eta_.item<double>();
    auto sums = torch::zeros({3}, torch::TensorOptions().dtype(torch::kFloat64).device(device_));
    for (int e = 0; e < c_.epochs; ++e) {
      opt_->zero_grad();
      for (int k = 0; k < K; ++k) {
        const auto adapted = adapt(theta(), pre_b[k], c_.inner_steps, !c_.first_order);
        auto surrogate = promp_surrogate(pi_, adapted, post_b[k], c_.clip);
        auto loss = surrogate;
        torch::Tensor kl = torch::zeros({}, surrogate.options());
        if (promp_) {
          kl = promp_kl(pi_, theta_old, theta(), pre_b[k].obs);
          loss = loss + eta * kl;
        }
        (loss / K).backward();
        torch::NoGradGuard ng;
        sums[0] += surrogate.detach().to(torch::kFloat64) / K;
        sums[1] += kl.detach().to(torch::kFloat64) / K;
      }
      const auto value_loss = (critic_->forward(all_obs).squeeze(-1) - all_ret).pow(2).mean();
      value_loss.backward();
      torch::nn::utils::clip_grad_norm_(params_->parameters(), c_.max_grad_norm);
      torch::nn::utils::clip_grad_norm_(critic_->parameters(), c_.max_grad_norm);
      if (alphas_) torch::nn::utils::clip_grad_norm_(alphas_->parameters(), c_.max_grad_norm);
      opt_->step();
      torch::NoGradGuard ng;
      sums[2] += value_loss.detach().to(torch::kFloat64);
    }
    double kl_after = 0;
    {
      torch::NoGradGuard ng;
      kl_after = pi_.kl(theta_old, theta(), pre_.obs.flatten(0, 1)).item<double>();
      if (promp_) {
        AdaptiveKlPenalty pen{eta, c_.target_kl};
        eta_.fill_(pen.update(kl_after));
      }
    }
    t_ = 0;
    const auto m = (sums / c_.epochs).to(torch::kCPU);
    torch::NoGradGuard ng;
    std::vector<double> out = {m[0].item<double>(),
                               m[1].item<double>(),
                               m[2].item<double>(),
                               kl_after,
                               eta_.item<double>(),
                               pre_.paid.mean().item<double>(),
                               post_.paid.mean().item<double>()};
    if (alphas_) {  // the learned step sizes' mean and range
      std::vector<torch::Tensor> v;
      for (auto& a : step_size().per_param) v.push_back(a.detach().flatten());
      const auto all = torch::cat(v);
      out.push_back(all.mean().item<double>());
      out.push_back(all.min().item<double>());
      out.push_back(all.max().item<double>());
    }
    return out;
  }

  const std::vector<std::string>& metric_names() const override {
    // reward_pre / reward_post: the mean reward per step before and after adaptation;
    // inner_lr_*: Meta-SGD's learned step sizes (learn_inner_lr)
    static const std::vector<std::string> names = {
        "surrogate", "kl_penalty", "value_loss", "kl", "kl_coef", "reward_pre", "reward_post"};
    static const std::vector<std::string> with_lr = [] {
      auto n = names;
      n.insert(n.end(), {"inner_lr_mean", "inner_lr_min", "inner_lr_max"});
      return n;
    }();
    return alphas_ ? with_lr : names;
  }

  void save(torch::serialize::OutputArchive& root) override {
    rl::write_part(root, "meta_policy", *params_);
    rl::write_part(root, "critic", *critic_);
    rl::write_part(root, "optimizer", *opt_);
    if (alphas_) rl::write_part(root, "inner_lr_log_scale", *alphas_);
    root.write("kl_coef", eta_);
    if (obs_norm_) rl::write_part(root, "obs_norm", *obs_norm_);
    if (scale_) scale_->save(root);
  }

  void load(torch::serialize::InputArchive& root, const std::string& path) override {
    rl::read_checked(path, "does not fit this run's networks", [&] {
      rl::read_module(root, "meta_policy", *params_, path, "this run's meta-policy");
      rl::read_module(root, "critic", *critic_, path, "this run's critic");
      rl::read_optimizer(root, "optimizer", *opt_);
      read_alphas(root, path);
      torch::Tensor eta;
      root.read("kl_coef", eta);
      eta_.copy_(eta.to(torch::kCPU));
      read_obs_norm(root, path);
      if (scale_) scale_->load(root);
    });
  }

  void load_actor(torch::serialize::InputArchive& root, const std::string& path) override {
    // the critic too: adaptation at evaluation needs its advantages
    rl::read_checked(path, "holds no meta-policy", [&] {
      rl::read_module(root, "meta_policy", *params_, path, "this run's meta-policy");
      rl::read_module(root, "critic", *critic_, path, "this run's critic");
      read_obs_norm(root, path);
      read_alphas(root, path);
    });
  }

  torch::Tensor actor(const torch::Tensor& obs) override {
    torch::NoGradGuard ng;
    return pi_.mean(theta(), in(obs)).clamp(-1, 1);
  }

  rl::Adaptive* adaptive() override { return this; }

  // --- evaluation (rl::Adaptive) ---
  void begin(const std::vector<int>& slot_task, int ntasks) override {
    eval_rows_ = group_slots(slot_task, ntasks);
    eval_adapted_.assign(ntasks, detached(theta()));
    eval_.clear();
    exploring_ = false;
  }

  torch::Tensor explore(const torch::Tensor& raw_obs) override {
    torch::NoGradGuard ng;
    const auto obs = in(raw_obs);
    auto [mean, log_std] = per_task(eval_adapted_, eval_rows_, obs);
    const auto a = mean + log_std.exp() * torch::randn_like(mean);
    EvalStep s;
    s.obs = obs;
    s.actions = a;
    s.logp = rl::gaussian_log_prob(a, mean, log_std);
    eval_.push_back(s);
    exploring_ = true;
    return a;
  }

  torch::Tensor exploit(const torch::Tensor& obs) override {
    torch::NoGradGuard ng;
    exploring_ = false;  // nothing to adapt from: observe() keeps no row of this step
    return per_task(eval_adapted_, eval_rows_, in(obs)).first.clamp(-1, 1);
  }

  void observe(const rl::Transition& t, const torch::Tensor& keep) override {
    torch::NoGradGuard ng;
    if (!exploring_) return;
    EvalStep& s = eval_.back();
    s.reward = t.reward.to(torch::kFloat32).clone();
    s.boot = bootstrap(t);
    s.done = t.done;
    s.keep = keep.clone();
  }

  void adapt(int steps) override {
    std::vector<EvalStep> kept;
    kept.swap(eval_);
    if (kept.empty() || steps == 0) return;
    auto stack = [&](torch::Tensor EvalStep::*field) {
      std::vector<torch::Tensor> v;
      for (auto& s : kept) v.push_back(s.*field);
      return torch::stack(v);
    };
    const auto obs = stack(&EvalStep::obs);
    const auto keep = stack(&EvalStep::keep);
    // a slot's rows end with its last kept episode's end: cut the recursion at every row that
    // is not kept, so that waiting steps add nothing
    const auto dones = torch::maximum(stack(&EvalStep::done), 1 - keep);
    torch::Tensor adv;
    {
      torch::NoGradGuard ng;
      auto rewards = stack(&EvalStep::reward);
      if (c_.task_reward_norm) {
        // a held-out task has no statistics: each task's scale is the std of its own kept
        // rows' returns (1 with fewer than two rows)
        const auto returns = discounted_returns(rewards, dones, c_.gamma);
        auto per_slot = torch::ones_like(rewards[0]);
        for (const auto& idx : eval_rows_) {
          const auto kept = returns.index_select(1, idx).index({keep.index_select(1, idx) > 0.5});
          if (kept.numel() < 2) continue;
          const double var = kept.var(/*unbiased=*/false).item<double>();
          per_slot.index_fill_(0, idx, 1.0 / std::sqrt(var + 1e-8));
        }
        rewards = (rewards * per_slot).clamp(-TaskReturnScale::kMaxScaled,
                                             TaskReturnScale::kMaxScaled);
      }
      const auto values = critic_->forward(obs).squeeze(-1);
      adv = rl::gae(rewards + stack(&EvalStep::boot), values, dones,
                    torch::zeros_like(values[0]), c_.gamma, c_.lambda)
                .first;
    }
    const auto actions = stack(&EvalStep::actions), logp = stack(&EvalStep::logp);
    for (size_t k = 0; k < eval_rows_.size(); ++k) {
      const auto& idx = eval_rows_[k];
      const Batch b = task_batch(obs, actions, adv, logp, idx, rows(keep, idx) > 0.5);
      if (b.obs.size(0) == 0) continue;
      eval_adapted_[k] = detached(adapt(eval_adapted_[k], b, steps, false));
    }
  }

 private:
  struct EvalStep {
    // obs as the networks read them; reward as the task pays it; boot: gamma V(last
    // observation) where the time limit cut an episode, else 0
    torch::Tensor obs, actions, logp, reward, boot, done, keep;
  };

  const std::vector<torch::Tensor>& theta() const { return params_->list; }

  // slot indices of each task, as index tensors on the device
  std::vector<torch::Tensor> group_slots(const std::vector<int>& slot_task, int ntasks) const {
    std::vector<std::vector<int64_t>> idx(ntasks);
    for (size_t s = 0; s < slot_task.size(); ++s) idx.at(slot_task[s]).push_back(int64_t(s));
    std::vector<torch::Tensor> out;
    for (auto& v : idx)
      if (!v.empty()) out.push_back(torch::tensor(v, torch::kLong).to(device_));
      else out.push_back(torch::empty({0}, torch::TensorOptions(torch::kLong).device(device_)));
    return out;
  }

  // The means and log-stds [N, A] of each slot's task's parameters.
  std::pair<torch::Tensor, torch::Tensor> per_task(
      const std::vector<std::vector<torch::Tensor>>& params,
      const std::vector<torch::Tensor>& task_rows, const torch::Tensor& obs) const {
    auto mean = torch::empty({obs.size(0), pi_.act_dim}, obs.options());
    auto log_std = torch::empty_like(mean);
    for (size_t k = 0; k < task_rows.size(); ++k) {
      const auto& idx = task_rows[k];
      if (idx.numel() == 0) continue;
      mean.index_copy_(0, idx, pi_.mean(params[k], obs.index_select(0, idx)));
      log_std.index_copy_(0, idx, pi_.log_std(params[k]).expand({idx.numel(), pi_.act_dim}));
    }
    return {mean, log_std};
  }

  // observations as the networks read them
  torch::Tensor in(const torch::Tensor& obs) const {
    return obs_norm_ ? obs_norm_->normalize(obs) : obs;
  }

  void read_obs_norm(torch::serialize::InputArchive& root, const std::string& path) {
    if (obs_norm_) rl::read_module(root, "obs_norm", *obs_norm_, path, "this run's obs_norm");
  }

  void read_alphas(torch::serialize::InputArchive& root, const std::string& path) {
    if (alphas_)
      rl::read_module(root, "inner_lr_log_scale", *alphas_, path,
                      "this run's learned inner step sizes");
  }

  // the inner step: inner_lr, or Meta-SGD's learned sizes inner_lr exp(rho) (in the graph: the
  // outer loss differentiates through them)
  StepSize step_size() const {
    if (!alphas_) return StepSize(c_.inner_lr);
    std::vector<torch::Tensor> a;
    for (auto& rho : alphas_->list) a.push_back(c_.inner_lr * rho.exp());
    return StepSize(c_.inner_lr, std::move(a));
  }

  // gamma V(last observation) where the time limit cut the step's episode, else 0, [N]
  torch::Tensor bootstrap(const rl::Transition& t) {
    auto b = torch::zeros({t.reward.size(0)}, t.reward.options().dtype(torch::kFloat32));
    if (t.final_ids.numel() > 0)
      b.index_add_(0, t.final_ids,
                   c_.gamma * critic_->forward(in(t.final_obs)).squeeze(-1).to(torch::kFloat32));
    return b;
  }

  // `steps` adaptation steps from `params` on one task's rows
  std::vector<torch::Tensor> adapt(const std::vector<torch::Tensor>& params, const Batch& b,
                                   int steps, bool create_graph) const {
    const StepSize lr = step_size();
    if (!promp_)
      return inner_steps(pi_, params, b.obs, b.actions, b.advantages, lr, steps, create_graph);
    std::vector<torch::Tensor> p = params;
    for (int i = 0; i < steps; ++i) p = lvc_inner_step(pi_, p, b, lr, create_graph);
    return p;
  }

  // Each task's adapted parameters from the pre-adaptation rollout (acting only: no graph);
  // keeps each task's rows and the returns for the outer update.
  std::vector<std::vector<torch::Tensor>> adapt_from_pre(const torch::Tensor& obs) {
    const auto last = critic_->forward(obs).squeeze(-1);
    torch::Tensor adv;
    std::tie(adv, pre_ret_) =
        rl::gae(pre_.rewards, pre_.values, pre_.dones, last, c_.gamma, c_.lambda);
    pre_batches_.clear();
    std::vector<std::vector<torch::Tensor>> out;
    torch::AutoGradMode grad_on(true);
    for (const auto& idx : task_rows_) {
      pre_batches_.push_back(task_batch(pre_.obs, pre_.actions, adv, pre_.logp, idx));
      out.push_back(detached(adapt(detached(theta()), pre_batches_.back(), c_.inner_steps,
                                   false)));
    }
    return out;
  }

  GradientMetaConfig c_;
  bool promp_;
  torch::Device device_;
  FunctionalGaussian pi_;  // the architecture; params_ holds the meta-parameters
  Params params_{nullptr};
  // learn_inner_lr: Meta-SGD's step sizes as rho, alpha = inner_lr exp(rho), one tensor per
  // parameter: positive, and on inner_lr's scale for the outer Adam's steps (config.h)
  Params alphas_{nullptr};
  torch::nn::Sequential critic_{nullptr};
  rl::RunningNorm obs_norm_{nullptr};        // input_norm
  std::unique_ptr<TaskReturnScale> scale_;   // task_reward_norm, when training
  std::unique_ptr<torch::optim::Adam> opt_;
  torch::Tensor eta_;  // ProMP's KL coefficient, [1] float64 on the CPU (checkpointed)
  std::vector<torch::Tensor> task_rows_;
  Phase pre_, post_;
  std::vector<Batch> pre_batches_;  // per task, from adapt_from_pre
  torch::Tensor pre_ret_;
  std::vector<std::vector<torch::Tensor>> adapted_;
  int64_t t_ = 0;
  // evaluation
  std::vector<torch::Tensor> eval_rows_;
  std::vector<std::vector<torch::Tensor>> eval_adapted_;
  std::vector<EvalStep> eval_;  // the exploration steps since begin()
  bool exploring_ = false;      // the last action came from explore()
};

std::unique_ptr<rl::Algorithm> make(const rl::TrainConfig& config, bool promp, int64_t D,
                                    int64_t A, int64_t N, const torch::Device& device) {
  const auto section = YamlView::load_string(config.section_yaml, config.algo + " section");
  return std::make_unique<GradientMeta>(read_gradient_meta(section, promp), promp, D, A, N,
                                        config.seed, device);
}

}  // namespace

std::unique_ptr<rl::Algorithm> make_maml(const rl::TrainConfig& config, int64_t obs_dim,
                                         int64_t act_dim, int64_t nslot,
                                         const torch::Device& device) {
  return make(config, false, obs_dim, act_dim, nslot, device);
}

std::unique_ptr<rl::Algorithm> make_promp(const rl::TrainConfig& config, int64_t obs_dim,
                                          int64_t act_dim, int64_t nslot,
                                          const torch::Device& device) {
  return make(config, true, obs_dim, act_dim, nslot, device);
}

}  // namespace bidex::metarl
