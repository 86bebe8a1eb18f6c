// TD3+BC (Fujimoto and Gu 2021): TD3 on the dataset's transitions, with a behaviour-cloning term
// in the actor's loss, -lambda mean Q1(s, pi(s)) + mean (pi(s) - a)^2, lambda = alpha / mean
// |Q1(s, pi(s))| (losses.h). Twin critics regress r + not_done gamma min(Q1', Q2') at the target
// actor's smoothed action (TD3's clipped noise); the actor and both targets move every
// policy_freq critic steps. The original's alpha is 0.2 (its config: `alpha: 0.2 #2.5`; the
// paper's is 2.5).
#include "offline/algorithms.h"
#include "offline/losses.h"
#include "rl/checkpoint.h"
#include "rl/policy.h"
#include "rl/td3.h"

namespace bidex::offline {

namespace {

class Td3bc final : public OfflineAlgorithm {
 public:
  Td3bc(const rl::TrainConfig& config, const Td3bcConfig& c, int64_t D, int64_t A,
        const torch::Device& device)
      : OfflineAlgorithm(config, c, D, A, device),
        c_(c),
        actor_(relu_mlp(D, c.hidden, A)),
        actor_target_(relu_mlp(D, c.hidden, A)),
        critic_(twin_q(D, A, c.hidden)),
        critic_target_(twin_q(D, A, c.hidden)) {
    for (torch::nn::Module* m : std::initializer_list<torch::nn::Module*>{
             actor_.get(), actor_target_.get(), critic_.get(), critic_target_.get()})
      m->to(device);
    rl::make_target(*actor_, *actor_target_);
    rl::make_target(*critic_, *critic_target_);
    actor_opt_ = std::make_unique<torch::optim::Adam>(actor_->parameters(),
                                                      torch::optim::AdamOptions(c.actor_lr));
    critic_opt_ = std::make_unique<torch::optim::Adam>(critic_->parameters(),
                                                       torch::optim::AdamOptions(c.critic_lr));
  }

  const std::vector<std::string>& metric_names() const override {
    static const std::vector<std::string> names = {"q_loss", "actor_loss", "bc_mse", "q_mean"};
    return names;
  }

 protected:
  std::vector<torch::Tensor> train_step(const Batch& b, int64_t step) override {
    torch::Tensor target;
    {
      torch::NoGradGuard ng;
      const auto mu = torch::tanh(actor_target_->forward(b.next_obs));
      const auto a_next =
          rl::td3_target_action(mu, torch::randn_like(mu), c_.policy_noise, c_.noise_clip);
      const auto [q1n, q2n] = critic_target_->forward(b.next_obs, a_next);
      target = b.reward + b.not_done * c_.gamma * torch::min(q1n, q2n);
    }
    const auto [q1, q2] = critic_->forward(b.obs, b.actions);
    // both critics' errors summed, as the original
    auto q_loss = (q1 - target).pow(2).mean() + (q2 - target).pow(2).mean();
    critic_opt_->zero_grad();
    q_loss.backward();
    critic_opt_->step();
    std::vector<torch::Tensor> m = {q_loss.detach(), {}, {}, q1.detach().mean()};
    if (rl::td3_actor_step(step, c_.policy_freq)) {
      const auto pi = torch::tanh(actor_->forward(b.obs));
      auto [loss, mse] = td3bc_actor_loss(critic_->first(b.obs, pi), pi, b.actions, c_.alpha);
      actor_opt_->zero_grad();
      loss.backward();
      actor_opt_->step();
      rl::polyak_update(*actor_, *actor_target_, 1 - c_.tau);
      rl::polyak_update(*critic_, *critic_target_, 1 - c_.tau);
      m[1] = loss.detach();
      m[2] = mse;
    }
    return m;
  }

  torch::Tensor policy(const torch::Tensor& nobs) override {
    return torch::tanh(actor_->forward(nobs));
  }

  void save_parts(torch::serialize::OutputArchive& root) override {
    rl::write_part(root, "actor", *actor_);
    rl::write_part(root, "actor_target", *actor_target_);
    rl::write_part(root, "critic", *critic_);
    rl::write_part(root, "critic_target", *critic_target_);
    rl::write_part(root, "actor_optimizer", *actor_opt_);
    rl::write_part(root, "critic_optimizer", *critic_opt_);
  }
  void load_parts(torch::serialize::InputArchive& root, const std::string& path) override {
    load_actor_parts(root, path);
    rl::read_module(root, "actor_target", *actor_target_, path, "this run's target actor");
    rl::read_module(root, "critic", *critic_, path, "this run's critics");
    rl::read_module(root, "critic_target", *critic_target_, path, "this run's target critics");
    rl::read_optimizer(root, "actor_optimizer", *actor_opt_);
    rl::read_optimizer(root, "critic_optimizer", *critic_opt_);
  }
  void load_actor_parts(torch::serialize::InputArchive& root, const std::string& path) override {
    rl::read_module(root, "actor", *actor_, path, "this run's actor");
  }

 private:
  Td3bcConfig c_;
  torch::nn::Sequential actor_, actor_target_;
  rl::QCritic critic_, critic_target_;
  std::unique_ptr<torch::optim::Adam> actor_opt_, critic_opt_;
};

}  // namespace

std::unique_ptr<OfflineAlgorithm> make_td3bc(const rl::TrainConfig& config, int64_t obs_dim,
                                             int64_t act_dim, int64_t,
                                             const torch::Device& device) {
  return std::make_unique<Td3bc>(config, read_td3bc(section_of(config)), obs_dim, act_dim,
                                 device);
}

}  // namespace bidex::offline
