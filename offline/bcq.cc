// BCQ (Fujimoto et al. 2019), continuous actions: a conditional VAE models the dataset's actions
// per state, a perturbation actor moves a decoded action by at most phi, and twin critics score
// them. Each step trains the VAE (reconstruction + 0.5 KL), the critics towards BCQ's soft
// clipped double-Q target over `target_samples` decoded, perturbed actions per next state, and
// the actor to maximise Q1 of its perturbation of decoded actions; both targets follow by
// Polyak averaging every step. Acting decodes `eval_candidates` actions per state, perturbs
// them and takes the one of the largest Q1: sampled latents make it stochastic, as the
// original's.
#include "offline/algorithms.h"
#include "offline/losses.h"
#include "rl/checkpoint.h"
#include "rl/policy.h"

namespace bidex::offline {

namespace {

// a + phi tanh(f(s, a)), clamped to the action box
struct PerturbImpl : torch::nn::Module {
  PerturbImpl(int64_t D, int64_t A, const std::vector<int>& hidden, double phi) : phi(phi) {
    net = register_module("net", relu_mlp(D + A, hidden, A));
  }
  torch::Tensor forward(const torch::Tensor& obs, const torch::Tensor& a) {
    return (a + phi * torch::tanh(net->forward(torch::cat({obs, a}, 1)))).clamp(-1, 1);
  }
  torch::nn::Sequential net{nullptr};
  double phi;
};
TORCH_MODULE(Perturb);

struct VaeImpl : torch::nn::Module {
  VaeImpl(int64_t D, int64_t A, const std::vector<int>& hidden) : latent(2 * A) {
    encoder = register_module("encoder", relu_trunk(D + A, hidden));
    mean = register_module("mean", torch::nn::Linear(hidden.back(), latent));
    log_std = register_module("log_std", torch::nn::Linear(hidden.back(), latent));
    decoder = register_module("decoder", relu_mlp(D + latent, hidden, A));
  }
  // (reconstruction, mean, std) of actions a [B, A] in states obs [B, D]
  std::tuple<torch::Tensor, torch::Tensor, torch::Tensor> forward(const torch::Tensor& obs,
                                                                  const torch::Tensor& a) {
    const auto h = encoder->forward(torch::cat({obs, a}, 1));
    auto m = mean->forward(h);
    auto sigma = log_std->forward(h).clamp(-4, 15).exp();
    return {decode(obs, m + sigma * torch::randn_like(sigma)), m, sigma};
  }
  // Actions for latents z, or for latents drawn from N(0, 1) clipped to +-0.5 (the original's
  // way of keeping decoded actions near the data's modes).
  torch::Tensor decode(const torch::Tensor& obs, torch::Tensor z = {}) {
    if (!z.defined()) z = torch::randn({obs.size(0), latent}, obs.options()).clamp(-0.5, 0.5);
    return torch::tanh(decoder->forward(torch::cat({obs, z}, 1)));
  }
  int64_t latent;
  torch::nn::Sequential encoder{nullptr}, decoder{nullptr};
  torch::nn::Linear mean{nullptr}, log_std{nullptr};
};
TORCH_MODULE(Vae);

class Bcq final : public OfflineAlgorithm {
 public:
  Bcq(const rl::TrainConfig& config, const BcqConfig& c, int64_t D, int64_t A,
      const torch::Device& device)
      : OfflineAlgorithm(config, c, D, A, device),
        c_(c),
        actor_(D, A, c.actor_hidden, c.phi),
        actor_target_(D, A, c.actor_hidden, c.phi),
        critic_(twin_q(D, A, c.critic_hidden)),
        critic_target_(twin_q(D, A, c.critic_hidden)),
        vae_(D, A, c.vae_hidden) {
    for (torch::nn::Module* m : std::initializer_list<torch::nn::Module*>{
             actor_.get(), actor_target_.get(), critic_.get(), critic_target_.get(), vae_.get()})
      m->to(device);
    rl::make_target(*actor_, *actor_target_);
    rl::make_target(*critic_, *critic_target_);
    actor_opt_ = std::make_unique<torch::optim::Adam>(actor_->parameters(),
                                                      torch::optim::AdamOptions(c.actor_lr));
    critic_opt_ = std::make_unique<torch::optim::Adam>(critic_->parameters(),
                                                       torch::optim::AdamOptions(c.critic_lr));
    vae_opt_ = std::make_unique<torch::optim::Adam>(vae_->parameters(),
                                                    torch::optim::AdamOptions(c.vae_lr));
  }

  const std::vector<std::string>& metric_names() const override {
    static const std::vector<std::string> names = {"vae_loss", "q_loss", "actor_loss",
                                                   "q_mean"};
    return names;
  }

 protected:
  std::vector<torch::Tensor> train_step(const Batch& b, int64_t) override {
    auto [recon, mean, sigma] = vae_->forward(b.obs, b.actions);
    auto vae_loss = bcq_vae_loss(recon, b.actions, mean, sigma);
    vae_opt_->zero_grad();
    vae_loss.backward();
    vae_opt_->step();

    torch::Tensor target, decoded;
    {
      torch::NoGradGuard ng;
      const auto next = b.next_obs.repeat_interleave(c_.target_samples, 0);
      const auto [q1n, q2n] = critic_target_->forward(next, actor_target_->forward(
                                                                next, vae_->decode(next)));
      target = bcq_target(q1n, q2n, c_.lmbda, b.reward, b.not_done, c_.gamma,
                          c_.target_samples);
      // the actor's inputs: the VAE learns nothing from the actor's loss
      decoded = vae_->decode(b.obs);
    }
    const auto [q1, q2] = critic_->forward(b.obs, b.actions);
    auto q_loss = (q1 - target).pow(2).mean() + (q2 - target).pow(2).mean();
    critic_opt_->zero_grad();
    q_loss.backward();
    critic_opt_->step();

    auto actor_loss = -critic_->first(b.obs, actor_->forward(b.obs, decoded)).mean();
    actor_opt_->zero_grad();
    actor_loss.backward();
    actor_opt_->step();

    rl::polyak_update(*critic_, *critic_target_, 1 - c_.tau);
    rl::polyak_update(*actor_, *actor_target_, 1 - c_.tau);
    return {vae_loss.detach(), q_loss.detach(), actor_loss.detach(), q1.detach().mean()};
  }

  torch::Tensor policy(const torch::Tensor& nobs) override {
    const int64_t n = nobs.size(0), K = c_.eval_candidates;
    const auto rep = nobs.repeat_interleave(K, 0);
    const auto cand = actor_->forward(rep, vae_->decode(rep));
    return bcq_pick(critic_->first(rep, cand).view({n, K}), cand.view({n, K, act_dim_}));
  }

  void save_parts(torch::serialize::OutputArchive& root) override {
    rl::write_part(root, "actor", *actor_);
    rl::write_part(root, "actor_target", *actor_target_);
    rl::write_part(root, "critic", *critic_);
    rl::write_part(root, "critic_target", *critic_target_);
    rl::write_part(root, "vae", *vae_);
    rl::write_part(root, "actor_optimizer", *actor_opt_);
    rl::write_part(root, "critic_optimizer", *critic_opt_);
    rl::write_part(root, "vae_optimizer", *vae_opt_);
  }
  void load_parts(torch::serialize::InputArchive& root, const std::string& path) override {
    load_actor_parts(root, path);
    rl::read_module(root, "actor_target", *actor_target_, path, "this run's target actor");
    rl::read_module(root, "critic_target", *critic_target_, path, "this run's target critics");
    rl::read_optimizer(root, "actor_optimizer", *actor_opt_);
    rl::read_optimizer(root, "critic_optimizer", *critic_opt_);
    rl::read_optimizer(root, "vae_optimizer", *vae_opt_);
  }
  // acting needs the VAE, the perturbation and the first critic
  void load_actor_parts(torch::serialize::InputArchive& root, const std::string& path) override {
    rl::read_module(root, "actor", *actor_, path, "this run's actor");
    rl::read_module(root, "critic", *critic_, path, "this run's critics");
    rl::read_module(root, "vae", *vae_, path, "this run's VAE");
  }

 private:
  BcqConfig c_;
  Perturb actor_, actor_target_;
  rl::QCritic critic_, critic_target_;
  Vae vae_;
  std::unique_ptr<torch::optim::Adam> actor_opt_, critic_opt_, vae_opt_;
};

}  // namespace

std::unique_ptr<OfflineAlgorithm> make_bcq(const rl::TrainConfig& config, int64_t obs_dim,
                                           int64_t act_dim, int64_t,
                                           const torch::Device& device) {
  return std::make_unique<Bcq>(config, read_bcq(section_of(config)), obs_dim, act_dim, device);
}

}  // namespace bidex::offline
