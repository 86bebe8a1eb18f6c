#include "rl/onpolicy.h"

#include <vector>

#include "rl/autocast.h"
#include "rl/checkpoint.h"

#ifdef BIDEX_TORCH_CUDA
#include "rl/cuda_graph.h"
#endif

namespace bidex::rl {

#ifdef BIDEX_TORCH_CUDA
struct GaussianOnPolicy::ActGraphs {
  ActGraphs(const torch::Tensor& like, int64_t horizon) : obs(torch::empty_like(like)) {
    const auto pool = at::cuda::graph_pool_handle();  // shared: the steps never run at once
    step.reserve(static_cast<size_t>(horizon));
    for (int64_t t = 0; t < horizon; ++t)
      step.emplace_back("PPO's act step", "ppo.act_graph", pool);
  }
  torch::Tensor obs;  // the graphs' input, at one address
  std::vector<GraphedSteps> step;  // one per rollout step
};
#else
struct GaussianOnPolicy::ActGraphs {};
#endif

GaussianOnPolicy::GaussianOnPolicy(const PpoConfig& config, int64_t D, int64_t A, int64_t N,
                                   const torch::Device& device, int64_t value_tasks)
    : c_(config), model_(D, A, config, value_tasks) {
  model_->to(device);
  ro_ = std::make_unique<Rollout>(c_.horizon, N, D, A, device);
  std_ = torch::empty_like(ro_->log_std);
}

GaussianOnPolicy::~GaussianOnPolicy() = default;

torch::Tensor GaussianOnPolicy::act(const torch::Tensor& obs) {
#ifdef BIDEX_TORCH_CUDA
  if (c_.act_graph && obs.is_cuda()) return graphed_act(obs);
#endif
  act_into_rollout(obs);
  return ro_->actions[t_];
}

void GaussianOnPolicy::act_into_rollout(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  if (t_ == 0) {  // the rollout's Gaussian keeps the log-std it started with
    ro_->log_std.copy_(model_->log_std().detach());
    torch::exp_out(std_, ro_->log_std);
  }
  if (c_.obs_norm) model_->obs_norm()->update(obs);
  auto nobs = model_->normalize_obs(obs);
  torch::Tensor mu, v;
  {
    Bf16Autocast bf16(nobs.device().type(), c_.bf16_act);  // the networks only
    mu = model_->mean(nobs).to(torch::kFloat32);
    v = model_->value(nobs);
  }
  auto a = mu + std_ * torch::randn_like(mu);
  ro_->nobs[t_].copy_(nobs);
  ro_->actions[t_].copy_(a);
  ro_->mu[t_].copy_(mu);
  ro_->values[t_].copy_(v);
  ro_->logp[t_].copy_(gaussian_log_prob(a, mu, ro_->log_std));
}

#ifdef BIDEX_TORCH_CUDA
torch::Tensor GaussianOnPolicy::graphed_act(const torch::Tensor& obs) {
  if (!graphs_) graphs_ = std::make_unique<ActGraphs>(obs, c_.horizon);
  graphs_->obs.copy_(obs);  // on the caller's stream, which the step's waits for
  // a step's first call is in the first rollout; its capture, in the second, comes after an
  // update has put the parameters in the optimiser's flat buffer
  auto& step = graphs_->step[static_cast<size_t>(t_)];
  if (!step.run([&] { act_into_rollout(graphs_->obs); })) c_.act_graph = false;
  return ro_->actions[t_];
}
#endif

void GaussianOnPolicy::observe(const Transition& t) {
  torch::NoGradGuard ng;
  auto rew = ro_->rewards[t_];
  rew.copy_(t.reward);
  ro_->dones[t_].copy_(t.done);
  // time limits: bootstrap from the critic's value of the final observation
  if (t.final_ids.numel() > 0)
    rew.index_add_(0, t.final_ids, c_.gamma * rollout_value(t.final_obs));
  t_ += 1;
}

torch::Tensor GaussianOnPolicy::finish_rollout(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  t_ = 0;
  return rollout_value(obs);
}

torch::Tensor GaussianOnPolicy::rollout_value(const torch::Tensor& obs) {
  const auto nobs = model_->normalize_obs(obs);
  Bf16Autocast bf16(nobs.device().type(), c_.bf16_act);
  return model_->value(nobs);
}

double GaussianOnPolicy::action_std() const {
  torch::NoGradGuard ng;
  return torch::exp(model_->log_std()).mean().item<double>();
}

void GaussianOnPolicy::load_actor(torch::serialize::InputArchive& root, const std::string& path) {
  read_checked(path, "holds no networks",
               [&] { read_module(root, "model", *model_, path, "this run's networks"); });
}

torch::Tensor GaussianOnPolicy::actor(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  return model_->mean(model_->normalize_obs(obs)).clamp(-1.0, 1.0);
}

torch::Tensor GaussianOnPolicy::sample_actor(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  auto mu = model_->mean(model_->normalize_obs(obs));
  return (mu + torch::exp(model_->log_std()) * torch::randn_like(mu)).clamp(-1.0, 1.0);
}

}  // namespace bidex::rl
