#include "marl/onpolicy.h"

#include <algorithm>
#include <tuple>

#include "core/error.h"
#include "marl/algorithms.h"
#include "rl/checkpoint.h"
#include "rl/ppo.h"

namespace bidex::marl {

torch::Tensor happo_surrogate(const torch::Tensor& ratio, const torch::Tensor& adv,
                              const torch::Tensor& factor, double clip) {
  // factor > 0, so factor x min(r A, c A) = min(r (factor A), c (factor A))
  return rl::clipped_surrogate(ratio, factor.defined() ? factor * adv : adv, clip);
}

torch::Tensor hatrpo_surrogate(const torch::Tensor& ratio, const torch::Tensor& adv,
                               const torch::Tensor& factor) {
  return -(factor.defined() ? factor * ratio * adv : ratio * adv).mean();
}

torch::Tensor next_factor(const torch::Tensor& factor, const torch::Tensor& logp_new,
                          const torch::Tensor& logp_old) {
  return (factor * torch::exp(logp_new - logp_old)).detach();
}

torch::Tensor ppo_actor_update(GaussianActor& actor, torch::optim::Optimizer& opt,
                               const AgentBatch& b, const torch::Tensor& factor,
                               const OnPolicyConfig& c) {
  const int64_t B = b.obs.size(0);
  const int64_t nmb = std::max<int64_t>(1, std::min<int64_t>(c.minibatches, B));
  const int64_t mb = std::max<int64_t>(1, B / nmb);
  const auto on = torch::TensorOptions().device(b.obs.device());
  auto sums = torch::zeros({4}, on.dtype(torch::kFloat64));
  const auto params = actor->parameters();
  int n = 0;
  for (int epoch = 0; epoch < c.epochs; ++epoch) {
    const auto perm = torch::randperm(B, on.dtype(torch::kLong));
    for (int64_t k = 0; k < nmb; ++k) {
      const auto idx = perm.narrow(0, k * mb, mb);
      const auto mu = actor->mean(b.obs.index_select(0, idx));
      const auto log_std = actor->log_std();
      const auto logp = rl::gaussian_log_prob(b.actions.index_select(0, idx), mu, log_std);
      const auto ratio = torch::exp(logp - b.logp_old.index_select(0, idx));
      const auto loss = happo_surrogate(ratio, b.adv.index_select(0, idx),
                                        factor.defined() ? factor.index_select(0, idx) : factor,
                                        c.clip);
      const auto entropy = rl::gaussian_entropy(log_std);
      opt.zero_grad();
      (loss - c.entropy_coef * entropy).backward();
      torch::nn::utils::clip_grad_norm_(params, c.max_grad_norm);
      opt.step();
      torch::NoGradGuard ng;
      const auto kl =
          rl::gaussian_kl(b.mu_old.index_select(0, idx), b.log_std_old, mu, log_std).mean();
      const auto clipped = ((ratio - 1.0).abs() > c.clip).to(torch::kFloat32).mean();
      sums += torch::stack({loss, entropy, kl, clipped}).to(torch::kFloat64);
      ++n;
    }
  }
  return sums / std::max(n, 1);
}

rl::NaturalStep trpo_actor_update(GaussianActor& actor, const AgentBatch& b,
                                  const torch::Tensor& factor, const OnPolicyConfig& c) {
  auto surrogate = [&] {
    const auto logp = actor->log_prob(b.obs, b.actions);
    return hatrpo_surrogate(torch::exp(logp - b.logp_old), b.adv, factor);
  };
  auto mean_kl = [&] {
    return rl::gaussian_kl(b.mu_old, b.log_std_old, actor->mean(b.obs), actor->log_std()).mean();
  };
  const rl::NaturalStepSettings s{c.kl_threshold, c.damping,      c.cg_iters,
                                  c.backtracks,   c.accept_ratio, 1.0};
  return rl::natural_step(actor->parameters(), surrogate, mean_kl, s);
}

OnPolicyMarl::OnPolicyMarl(OnPolicyMode mode, const OnPolicyConfig& config,
                           const AgentSplit& split, int64_t nslot, const torch::Device& device,
                           const std::string& algo)
    : mode_(mode),
      c_(config),
      views_(split, device),
      T_(config.horizon),
      N_(nslot),
      D_(split.obs_dim),
      A_(split.act_dim) {
  const int64_t n = views_.count();
  shared_ = mode == OnPolicyMode::kCentralised && c_.share_actor;
  if (shared_) {
    bool equal = true;
    for (int64_t i = 1; i < n; ++i)
      equal = equal && views_.obs_dim(i) == views_.obs_dim(0) &&
              views_.act_dim(i) == views_.act_dim(0);
    if (!equal) {
      std::string w;
      for (int64_t i = 0; i < n; ++i)
        w += std::string(i ? ", " : "") + split.agents[i].name + " sees " +
             std::to_string(views_.obs_dim(i)) + " and acts on " +
             std::to_string(views_.act_dim(i));
      throw Error(algo + ".share_actor: one actor for all agents needs agents of equal "
                  "observation and action widths; this " + split.kind + " split's: " + w);
    }
  }
  for (int64_t i = 0; i < (shared_ ? 1 : n); ++i) {
    actors_.emplace_back(views_.obs_dim(i), views_.act_dim(i), c_);
    actor_list_->push_back(actors_.back());
  }
  C_ = mode == OnPolicyMode::kIndependent ? n : 1;
  for (int64_t i = 0; i < C_; ++i) {
    critics_.emplace_back(C_ > 1 ? views_.obs_dim(i) : D_, c_.net);
    critic_list_->push_back(critics_.back());
    value_norms_.emplace_back(1, 1e9);
    value_norm_list_->push_back(value_norms_.back());
  }
  obs_norm_ = rl::RunningNorm(D_);
  actor_list_->to(device);
  critic_list_->to(device);
  value_norm_list_->to(device);
  obs_norm_->to(device);
  const auto adam = [&](double lr) { return torch::optim::AdamOptions(lr).eps(c_.adam_eps); };
  if (mode != OnPolicyMode::kSequentialTrpo)
    for (auto& a : actors_)
      actor_opts_.push_back(std::make_unique<torch::optim::Adam>(a->parameters(), adam(c_.lr)));
  for (auto& v : critics_)
    critic_opts_.push_back(
        std::make_unique<torch::optim::Adam>(v->parameters(), adam(c_.critic_lr)));

  const auto f = torch::TensorOptions().dtype(torch::kFloat32).device(device);
  obs_ = torch::zeros({T_, N_, D_}, f);
  actions_ = torch::zeros({T_, N_, A_}, f);
  mu_ = torch::zeros({T_, N_, A_}, f);
  logp_ = torch::zeros({T_, N_, n}, f);
  values_ = torch::zeros({T_, N_, C_}, f);
  rewards_ = torch::zeros({T_, N_, C_}, f);
  dones_ = torch::zeros({T_, N_}, f);
  log_std_old_.resize(actors_.size());
  std_old_.resize(actors_.size());
}

torch::Tensor OnPolicyMarl::normalize_obs(const torch::Tensor& obs) const {
  return c_.obs_norm ? obs_norm_->normalize(obs) : obs;
}

std::vector<torch::Tensor> OnPolicyMarl::agent_views(const torch::Tensor& nobs) const {
  std::vector<torch::Tensor> v;
  for (int64_t i = 0; i < views_.count(); ++i) v.push_back(views_.obs(nobs, i));
  return v;
}

torch::Tensor OnPolicyMarl::critic_values(const torch::Tensor& nobs,
                                          const std::vector<torch::Tensor>& view) {
  std::vector<torch::Tensor> cols;
  for (int64_t k = 0; k < C_; ++k) {
    auto v = critics_[k]->forward(C_ > 1 ? view[k] : nobs);
    if (c_.value_norm) v = value_norms_[k]->denormalize(v);
    cols.push_back(v);
  }
  return torch::stack(cols, -1);
}

torch::Tensor OnPolicyMarl::values(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  const auto nobs = normalize_obs(obs);
  return critic_values(nobs, agent_views(nobs));
}

torch::Tensor OnPolicyMarl::act(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  if (t_ == 0)  // the rollout's Gaussians keep the std they started with
    for (size_t k = 0; k < actors_.size(); ++k) {
      log_std_old_[k] = actors_[k]->log_std().detach();
      std_old_[k] = torch::exp(log_std_old_[k]);
    }
  if (c_.obs_norm) obs_norm_->update(obs);
  const auto nobs = normalize_obs(obs);
  const auto view = agent_views(nobs);
  const int64_t n = views_.count();
  std::vector<torch::Tensor> mus, acts, logps;
  for (int64_t i = 0; i < n; ++i) {
    const int64_t k = shared_ ? 0 : i;
    auto mu = actors_[k]->mean(view[i]);
    auto a = mu + std_old_[k] * torch::randn_like(mu);
    logps.push_back(rl::gaussian_log_prob(a, mu, log_std_old_[k]));
    mus.push_back(std::move(mu));
    acts.push_back(std::move(a));
  }
  auto a = views_.assemble(acts);
  obs_[t_].copy_(nobs);
  actions_[t_].copy_(a);
  mu_[t_].copy_(views_.assemble(mus));
  logp_[t_].copy_(torch::stack(logps, -1));
  values_[t_].copy_(critic_values(nobs, view));
  return a;
}

void OnPolicyMarl::observe(const rl::Transition& t) {
  torch::NoGradGuard ng;
  auto rew = rewards_[t_];
  rew.copy_(t.reward.unsqueeze(-1).expand({N_, C_}));
  dones_[t_].copy_(t.done);
  // time limits: bootstrap from the critics' values of the final observation
  if (t.final_ids.numel() > 0) {
    const auto nf = normalize_obs(t.final_obs);
    rew.index_add_(0, t.final_ids, c_.gamma * critic_values(nf, agent_views(nf)));
  }
  t_ += 1;
}

std::vector<double> OnPolicyMarl::update(const torch::Tensor& obs) {
  const int64_t n = views_.count(), B = T_ * N_;
  torch::Tensor adv, ret;
  {
    torch::NoGradGuard ng;
    const auto last = values(obs);
    std::tie(adv, ret) = rl::gae(rewards_, values_, dones_.unsqueeze(-1).expand_as(rewards_),
                                 last, c_.gamma, c_.lambda);
  }
  t_ = 0;
  adv = adv.reshape({B, C_});
  adv = (adv - adv.mean(0)) / (adv.std(0) + 1e-5);
  ret = ret.reshape({B, C_});
  const auto values_old = values_.reshape({B, C_});
  const auto obs_b = obs_.reshape({B, D_});
  const auto actions_b = actions_.reshape({B, A_});
  const auto mu_b = mu_.reshape({B, A_});
  const auto logp_b = logp_.reshape({B, n});
  const auto view = agent_views(obs_b);
  auto batch = [&](int64_t i) {
    return AgentBatch{view[i],
                      views_.actions(actions_b, i),
                      logp_b.select(1, i),
                      views_.actions(mu_b, i),
                      log_std_old_[shared_ ? 0 : i],
                      adv.select(1, C_ > 1 ? i : 0)};
  };

  // the actors
  const auto on = torch::TensorOptions().device(obs_b.device());
  auto stats = torch::zeros({4}, on.dtype(torch::kFloat64));
  if (shared_) {  // one actor on every agent's rows
    std::vector<AgentBatch> parts;
    for (int64_t i = 0; i < n; ++i) parts.push_back(batch(i));
    auto cat = [&](torch::Tensor AgentBatch::*m) {
      std::vector<torch::Tensor> ts;
      for (auto& p : parts) ts.push_back(p.*m);
      return torch::cat(ts);
    };
    const AgentBatch all{cat(&AgentBatch::obs),    cat(&AgentBatch::actions),
                         cat(&AgentBatch::logp_old), cat(&AgentBatch::mu_old),
                         log_std_old_[0],            cat(&AgentBatch::adv)};
    stats += ppo_actor_update(actors_[0], *actor_opts_[0], all, {}, c_);
  } else if (mode_ == OnPolicyMode::kIndependent || mode_ == OnPolicyMode::kCentralised) {
    for (int64_t i = 0; i < n; ++i)
      stats += ppo_actor_update(actors_[i], *actor_opts_[i], batch(i), {}, c_);
  } else {
    std::vector<int64_t> order(n);
    if (c_.fixed_order) {
      for (int64_t i = 0; i < n; ++i) order[i] = i;
    } else {
      const auto perm = torch::randperm(n, torch::kLong);
      for (int64_t i = 0; i < n; ++i) order[i] = perm[i].item<int64_t>();
    }
    auto factor = torch::ones({B}, on.dtype(torch::kFloat32));
    for (int64_t j = 0; j < n; ++j) {
      const int64_t i = order[j];
      const AgentBatch b = batch(i);
      if (mode_ == OnPolicyMode::kSequentialPpo) {
        stats += ppo_actor_update(actors_[i], *actor_opts_[i], b, factor, c_);
      } else {
        const rl::NaturalStep st = trpo_actor_update(actors_[i], b, factor, c_);
        torch::NoGradGuard ng;
        stats += torch::stack({torch::tensor(st.loss, on.dtype(torch::kFloat64)),
                               actors_[i]->entropy().to(torch::kFloat64),
                               torch::tensor(st.kl, on.dtype(torch::kFloat64)),
                               torch::tensor(st.fraction, on.dtype(torch::kFloat64))});
      }
      if (j + 1 < n) {
        torch::NoGradGuard ng;
        factor = next_factor(factor, actors_[i]->log_prob(b.obs, b.actions), b.logp_old);
      }
    }
  }
  stats /= static_cast<double>(actors_.size());

  // the critics: Adam on the returns (normalised when value_norm)
  const int64_t nmb = std::max<int64_t>(1, std::min<int64_t>(c_.minibatches, B));
  const int64_t mb = std::max<int64_t>(1, B / nmb);
  auto value_sum = torch::zeros({}, on.dtype(torch::kFloat64));
  int steps = 0;
  for (int64_t k = 0; k < C_; ++k) {
    const auto in = C_ > 1 ? view[k] : obs_b;
    torch::Tensor targets = ret.select(1, k), v_old = values_old.select(1, k);
    if (c_.value_norm) {
      value_norms_[k]->update(targets.unsqueeze(1));
      targets = value_norms_[k]->normalize(targets.unsqueeze(1)).squeeze(1);
      v_old = value_norms_[k]->normalize(v_old.unsqueeze(1)).squeeze(1);
    }
    const auto params = critics_[k]->parameters();
    for (int epoch = 0; epoch < c_.epochs; ++epoch) {
      const auto perm = torch::randperm(B, on.dtype(torch::kLong));
      for (int64_t m = 0; m < nmb; ++m) {
        const auto idx = perm.narrow(0, m * mb, mb);
        const auto v = critics_[k]->forward(in.index_select(0, idx));
        const auto tgt = targets.index_select(0, idx);
        auto loss = value_error(v - tgt, c_.huber_delta);
        if (c_.clip_value_loss) {
          const auto vo = v_old.index_select(0, idx);
          const auto v_clipped = vo + torch::clamp(v - vo, -c_.clip, c_.clip);
          loss = torch::max(loss, value_error(v_clipped - tgt, c_.huber_delta));
        }
        loss = loss.mean();
        critic_opts_[k]->zero_grad();
        (c_.value_coef * loss).backward();
        torch::nn::utils::clip_grad_norm_(params, c_.max_grad_norm);
        critic_opts_[k]->step();
        value_sum += loss.detach().to(torch::kFloat64);
        ++steps;
      }
    }
  }

  torch::NoGradGuard ng;
  auto std_sum = torch::zeros({}, on.dtype(torch::kFloat64));
  for (auto& a : actors_) std_sum += a->std().mean().to(torch::kFloat64);
  const auto m = torch::stack({stats[0], value_sum / std::max(steps, 1), stats[1], stats[2],
                               stats[3], std_sum / static_cast<double>(actors_.size())})
                     .to(torch::kCPU);
  const auto p = m.data_ptr<double>();
  return std::vector<double>(p, p + m.numel());
}

const std::vector<std::string>& OnPolicyMarl::metric_names() const {
  static const std::vector<std::string> ppo = {"policy_loss", "value_loss",    "entropy",
                                               "kl",          "clip_fraction", "action_std"};
  static const std::vector<std::string> trpo = {"policy_loss", "value_loss",    "entropy",
                                                "kl",          "step_fraction", "action_std"};
  return mode_ == OnPolicyMode::kSequentialTrpo ? trpo : ppo;
}

void OnPolicyMarl::save(torch::serialize::OutputArchive& root) {
  write_split(root, views_.split());
  rl::write_part(root, "actors", *actor_list_);
  rl::write_part(root, "critics", *critic_list_);
  rl::write_part(root, "value_norms", *value_norm_list_);
  rl::write_part(root, "obs_norm", *obs_norm_);
  rl::write_optimizers(root, "actor_optimizer_", actor_opts_);
  rl::write_optimizers(root, "critic_optimizer_", critic_opts_);
}

void OnPolicyMarl::load(torch::serialize::InputArchive& root, const std::string& path) {
  rl::read_checked(path, "does not fit this run's networks", [&] {
    check_split(root, views_.split(), path);
    rl::read_module(root, "actors", *actor_list_, path, "this run's actors");
    rl::read_module(root, "critics", *critic_list_, path, "this run's critics");
    rl::read_module(root, "value_norms", *value_norm_list_, path, "this run's critics");
    rl::read_module(root, "obs_norm", *obs_norm_, path, "this run's observation normaliser");
    rl::read_optimizers(root, "actor_optimizer_", actor_opts_);
    rl::read_optimizers(root, "critic_optimizer_", critic_opts_);
  });
}

void OnPolicyMarl::load_actor(torch::serialize::InputArchive& root, const std::string& path) {
  rl::read_checked(path, "holds no actors of this run", [&] {
    check_split(root, views_.split(), path);
    rl::read_module(root, "actors", *actor_list_, path, "this run's actors");
    rl::read_module(root, "obs_norm", *obs_norm_, path, "this run's observation normaliser");
  });
}

torch::Tensor OnPolicyMarl::actor(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  const auto nobs = normalize_obs(obs);
  std::vector<torch::Tensor> parts;
  for (int64_t i = 0; i < views_.count(); ++i)
    parts.push_back(actor_of(i)->mean(views_.obs(nobs, i)));
  return views_.assemble(parts).clamp(-1.0, 1.0);
}

torch::Tensor OnPolicyMarl::sample_actor(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  const auto nobs = normalize_obs(obs);
  std::vector<torch::Tensor> parts;
  for (int64_t i = 0; i < views_.count(); ++i) {
    auto& a = actor_of(i);
    const auto mu = a->mean(views_.obs(nobs, i));
    parts.push_back(mu + a->std() * torch::randn_like(mu));
  }
  return views_.assemble(parts).clamp(-1.0, 1.0);
}

namespace {

std::unique_ptr<rl::Algorithm> make(OnPolicyMode mode, const rl::TrainConfig& config,
                                    int64_t obs_dim, int64_t act_dim, int64_t nslot,
                                    const torch::Device& device) {
  const OnPolicyConfig c = read_onpolicy(section_of(config), config.algo);
  const AgentSplit split = run_agents(config, obs_dim, act_dim);
  return std::make_unique<OnPolicyMarl>(mode, c, split, nslot, device, config.algo);
}

}  // namespace

std::unique_ptr<rl::Algorithm> make_ippo(const rl::TrainConfig& config, int64_t obs_dim,
                                         int64_t act_dim, int64_t nslot,
                                         const torch::Device& device) {
  return make(OnPolicyMode::kIndependent, config, obs_dim, act_dim, nslot, device);
}

std::unique_ptr<rl::Algorithm> make_mappo(const rl::TrainConfig& config, int64_t obs_dim,
                                          int64_t act_dim, int64_t nslot,
                                          const torch::Device& device) {
  return make(OnPolicyMode::kCentralised, config, obs_dim, act_dim, nslot, device);
}

std::unique_ptr<rl::Algorithm> make_happo(const rl::TrainConfig& config, int64_t obs_dim,
                                          int64_t act_dim, int64_t nslot,
                                          const torch::Device& device) {
  return make(OnPolicyMode::kSequentialPpo, config, obs_dim, act_dim, nslot, device);
}

std::unique_ptr<rl::Algorithm> make_hatrpo(const rl::TrainConfig& config, int64_t obs_dim,
                                           int64_t act_dim, int64_t nslot,
                                           const torch::Device& device) {
  return make(OnPolicyMode::kSequentialTrpo, config, obs_dim, act_dim, nslot, device);
}

}  // namespace bidex::marl
