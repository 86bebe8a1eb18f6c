#include "rl/sac.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "rl/checkpoint.h"
#include "rl/flat_adam.h"
#include "rl/policy.h"
#include "rl/replay.h"
#include "rl/suite_tasks.h"

#ifdef BIDEX_TORCH_CUDA
#include "rl/cuda_graph.h"
#endif

namespace bidex::rl {

torch::Tensor sac_q_target(const torch::Tensor& reward, const torch::Tensor& terminal,
                           const torch::Tensor& q1_next, const torch::Tensor& q2_next,
                           const torch::Tensor& logp_next, const torch::Tensor& alpha,
                           double gamma) {
  return reward + gamma * (1 - terminal) * (torch::min(q1_next, q2_next) - alpha * logp_next);
}

torch::Tensor sac_q_target(const torch::Tensor& reward, const torch::Tensor& terminal,
                           const torch::Tensor& q1_next, const torch::Tensor& q2_next,
                           const torch::Tensor& logp_next, double alpha, double gamma) {
  return sac_q_target(reward, terminal, q1_next, q2_next, logp_next,
                      torch::scalar_tensor(alpha, logp_next.options()), gamma);
}

torch::Tensor sac_alpha_loss(const torch::Tensor& log_alpha, const torch::Tensor& logp,
                             double target_entropy) {
  return -(log_alpha * (logp + target_entropy).detach()).mean();
}

torch::Tensor tanh_gaussian_log_prob(const torch::Tensor& u, const torch::Tensor& mean,
                                     const torch::Tensor& log_std) {
  // log(1 - tanh(u)^2) = 2 (log 2 - u - softplus(-2u)), stable for large |u|
  const auto log_det = 2 * (std::log(2.0) - u - torch::nn::functional::softplus(-2 * u));
  return gaussian_log_prob(u, mean, log_std) - log_det.sum(-1);
}

namespace {

constexpr double kLogStdMin = -20, kLogStdMax = 2;

// The actor: one network giving the mean and log-std of the pre-squash Gaussian.
struct SacActorImpl : torch::nn::Module {
  SacActorImpl(int64_t D, int64_t A, const SacConfig& c) : act_dim(A) {
    net = register_module("net", mlp(D, c.hidden, 2 * A, c.activation, 0.01));
  }
  std::pair<torch::Tensor, torch::Tensor> forward(const torch::Tensor& obs) {
    auto out = net->forward(obs);
    return {out.narrow(1, 0, act_dim),
            out.narrow(1, act_dim, act_dim).clamp(kLogStdMin, kLogStdMax)};
  }
  // a sampled (reparameterised) action in (-1, 1) and its log-probability
  std::pair<torch::Tensor, torch::Tensor> sample(const torch::Tensor& obs) {
    auto [mu, log_std] = forward(obs);
    auto u = mu + torch::exp(log_std) * torch::randn_like(mu);
    return {torch::tanh(u), tanh_gaussian_log_prob(u, mu, log_std)};
  }
  int64_t act_dim;
  torch::nn::Sequential net{nullptr};
};
TORCH_MODULE(SacActor);

class SacAlgorithm final : public Algorithm {
 public:
  // ntasks > 0: one temperature per task, read from the last ntasks columns (the one-hot id)
  SacAlgorithm(const TrainConfig& config, int64_t D, int64_t A, int64_t N,
               const torch::Device& device, int64_t ntasks = 0)
      : c_(config.sac),
        ntasks_(ntasks),
        actor_(D, A, config.sac),
        critic_(D, A, config.sac.hidden, config.sac.activation, true),
        target_(D, A, config.sac.hidden, config.sac.activation, true),
        target_entropy_(-static_cast<double>(A)) {
    actor_->to(device);
    critic_->to(device);
    target_->to(device);
    make_target(*critic_, *target_);
    log_alpha_ = torch::full({std::max<int64_t>(ntasks, 1)}, std::log(c_.init_alpha),
                             torch::TensorOptions().dtype(torch::kFloat32).device(device))
                     .set_requires_grad(true);
    // on the device now: FlatAdam moves the parameters into its flat buffers (rl/flat_adam.h)
    actor_opt_ = std::make_unique<FlatAdam>(actor_->parameters(), c_.lr);
    critic_opt_ = std::make_unique<FlatAdam>(critic_->parameters(), c_.lr);
    alpha_opt_ = std::make_unique<FlatAdam>(std::vector<torch::Tensor>{log_alpha_}, c_.lr);
    if (N > 0) replay_ = std::make_unique<ReplayBuffer>(c_.replay_size, D, A, device);
  }

  int steps_per_update() const override { return c_.horizon; }

  torch::Tensor act(const torch::Tensor& obs) override {
    torch::NoGradGuard ng;
    last_obs_ = obs;
    last_act_ = actor_->sample(obs).first;
    return last_act_;
  }

  void observe(const Transition& t) override {
    replay_->add(last_obs_, last_act_, t, c_.reward_scale);
  }

  std::vector<double> update(const torch::Tensor&) override {
    const auto dev = log_alpha_.device();
    if (!sums_.defined() || sums_.device() != dev)
      sums_ = torch::zeros({6}, torch::TensorOptions().dtype(torch::kFloat64).device(dev));
    bool eager = true;
#ifdef BIDEX_TORCH_CUDA
    // a graph replays one fixed sequence: the buffer's size (the sampled range) must be the
    // same at every update (rl/cuda_graph.h)
    if (c_.cuda_graph && dev.is_cuda() && replay_->size() == replay_->capacity()) {
      eager = false;
      if (!graph_)
        graph_ = std::make_unique<GraphedSteps>(
            ntasks_ > 0 ? "multi-task SAC's gradient steps" : "SAC's gradient steps",
            "sac.cuda_graph");
      actor_opt_->rebind();
      critic_opt_->rebind();
      alpha_opt_->rebind();
      if (!graph_->run([&] { gradient_steps(); })) c_.cuda_graph = false;
    }
#endif
    if (eager) gradient_steps();
    auto m = (sums_ / c_.minibatches).to(torch::kCPU);
    return {m[0].item<double>(), m[1].item<double>(), m[2].item<double>(), m[3].item<double>(),
            m[4].item<double>(), m[5].item<double>()};
  }

  // An update's gradient steps, their statistics summed into sums_; nothing read back, so that
  // a CUDA graph can capture them
  void gradient_steps() {
    sums_.zero_();
    for (int k = 0; k < c_.minibatches; ++k) {
      const auto b = replay_->sample(c_.batch_size);
      // each row's temperature (one task: the one), and the log of it for the temperature loss
      const torch::Tensor row_log_alpha =
          ntasks_ > 0 ? log_alpha_.index_select(0, task_ids(b.obs, ntasks_)) : log_alpha_;
      const torch::Tensor alpha = torch::exp(row_log_alpha).detach();
      // critics
      torch::Tensor target;
      {
        torch::NoGradGuard ng;
        auto [a_next, logp_next] = actor_->sample(b.next_obs);
        auto [q1n, q2n] = target_->forward(b.next_obs, a_next);
        const torch::Tensor alpha_next =
            ntasks_ > 0 ? torch::exp(log_alpha_.index_select(0, task_ids(b.next_obs, ntasks_)))
                        : alpha;
        target = sac_q_target(b.rewards, b.terminal, q1n, q2n, logp_next, alpha_next, c_.gamma);
      }
      auto [q1, q2] = critic_->forward(b.obs, b.actions);
      auto q_loss = 0.5 * ((q1 - target).pow(2).mean() + (q2 - target).pow(2).mean());
      // Each optimiser's loss reaches every one of its parameters, so that no gradient is
      // undefined at a step (FlatAdam would step it as zero where LibTorch's Adam skipped it),
      // and each zero_grad() comes before its loss's backward (the actor's loss also reaches
      // the critics: the next critic step zeroes that first)
      critic_opt_->zero_grad();
      q_loss.backward();
      critic_opt_->clip_grad_norm(c_.max_grad_norm);
      critic_opt_->step();
      // actor
      auto [a_new, logp] = actor_->sample(b.obs);
      auto [q1p, q2p] = critic_->forward(b.obs, a_new);
      auto actor_loss = (alpha * logp - torch::min(q1p, q2p)).mean();
      actor_opt_->zero_grad();
      actor_loss.backward();
      actor_opt_->clip_grad_norm(c_.max_grad_norm);
      actor_opt_->step();
      // temperature
      auto alpha_loss = sac_alpha_loss(row_log_alpha, logp, target_entropy_);
      if (c_.learn_alpha) {
        alpha_opt_->zero_grad();
        alpha_loss.backward();
        alpha_opt_->step();
      }
      polyak_update(*critic_, *target_, c_.polyak);
      torch::NoGradGuard ng;
      sums_ += torch::stack({q_loss.detach(), actor_loss.detach(), alpha_loss.detach(),
                             -logp.detach().mean(), q1.detach().mean(),
                             torch::exp(log_alpha_.detach()).mean()})
                   .to(torch::kFloat64);
    }
  }

  const std::vector<std::string>& metric_names() const override {
    static const std::vector<std::string> names = {"q_loss",  "actor_loss", "alpha_loss",
                                                   "entropy", "q_mean",     "alpha"};
    return names;
  }

  void save(torch::serialize::OutputArchive& root) override {
    write_part(root, "actor", *actor_);
    write_part(root, "critic", *critic_);
    write_part(root, "target", *target_);
    write_part(root, "actor_optimizer", *actor_opt_);
    write_part(root, "critic_optimizer", *critic_opt_);
    write_part(root, "alpha_optimizer", *alpha_opt_);
    root.write("log_alpha", log_alpha_.detach());
  }

  void load(torch::serialize::InputArchive& root, const std::string& path) override {
    read_checked(path, "does not fit this run's networks", [&] {
      read_module(root, "actor", *actor_, path, "this run's actor");
      read_module(root, "critic", *critic_, path, "this run's critics");
      read_module(root, "target", *target_, path, "this run's target critics");
      read_optimizer(root, "actor_optimizer", *actor_opt_);
      read_optimizer(root, "critic_optimizer", *critic_opt_);
      read_optimizer(root, "alpha_optimizer", *alpha_opt_);
      torch::Tensor la;
      root.read("log_alpha", la);
      torch::NoGradGuard ng;
      log_alpha_.copy_(la);
    });
  }

  void load_actor(torch::serialize::InputArchive& root, const std::string& path) override {
    read_checked(path, "holds no actor",
                 [&] { read_module(root, "actor", *actor_, path, "this run's actor"); });
  }

  torch::Tensor actor(const torch::Tensor& obs) override {
    torch::NoGradGuard ng;
    return torch::tanh(actor_->forward(obs).first);
  }

 private:
  SacConfig c_;
  int64_t ntasks_;
  SacActor actor_;
  QCritic critic_, target_;
  torch::Tensor log_alpha_;
  double target_entropy_;
  std::unique_ptr<FlatAdam> actor_opt_, critic_opt_, alpha_opt_;
  std::unique_ptr<ReplayBuffer> replay_;
  torch::Tensor last_obs_, last_act_;
  torch::Tensor sums_;  // an update's statistics, summed on the device
#ifdef BIDEX_TORCH_CUDA
  std::unique_ptr<GraphedSteps> graph_;
#endif
};

}  // namespace

std::unique_ptr<Algorithm> make_sac(const TrainConfig& config, int64_t obs_dim, int64_t act_dim,
                                    int64_t nslot, const torch::Device& device) {
  return std::make_unique<SacAlgorithm>(config, obs_dim, act_dim, nslot, device);
}

std::unique_ptr<Algorithm> make_mtsac(const TrainConfig& config, int64_t obs_dim,
                                      int64_t act_dim, int64_t nslot,
                                      const torch::Device& device) {
  const int64_t ntasks = suite_task_count(config, obs_dim, "mtsac");
  return std::make_unique<SacAlgorithm>(config, obs_dim, act_dim, nslot, device, ntasks);
}

}  // namespace bidex::rl
