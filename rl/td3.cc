#include "rl/td3.h"

#include "rl/checkpoint.h"
#include "rl/flat_adam.h"
#include "rl/policy.h"
#include "rl/replay.h"

#ifdef BIDEX_TORCH_CUDA
#include "rl/cuda_graph.h"
#endif

namespace bidex::rl {

torch::Tensor td3_target_action(const torch::Tensor& mu_next, const torch::Tensor& noise,
                                double std, double clip) {
  return (mu_next + (noise * std).clamp(-clip, clip)).clamp(-1, 1);
}

torch::Tensor td3_q_target(const torch::Tensor& reward, const torch::Tensor& terminal,
                           const torch::Tensor& q1_next, const torch::Tensor& q2_next,
                           double gamma) {
  return reward + gamma * (1 - terminal) * torch::min(q1_next, q2_next);
}

torch::Tensor td3_actor_loss(const torch::Tensor& q, const torch::Tensor& preact,
                             double preact_l2) {
  auto loss = -q.mean();
  return preact_l2 > 0 ? loss + preact_l2 * preact.pow(2).mean() : loss;
}

namespace {

struct Td3ActorImpl : torch::nn::Module {
  Td3ActorImpl(int64_t D, int64_t A, const Td3Config& c) {
    net = register_module("net", mlp(D, c.hidden, A, c.activation, 0.01));
  }
  torch::Tensor forward(const torch::Tensor& obs) { return torch::tanh(net->forward(obs)); }
  torch::Tensor preactivation(const torch::Tensor& obs) { return net->forward(obs); }
  torch::nn::Sequential net{nullptr};
};
TORCH_MODULE(Td3Actor);

class Td3Algorithm final : public Algorithm {
 public:
  Td3Algorithm(const TrainConfig& config, int64_t D, int64_t A, int64_t N,
               const torch::Device& device)
      : c_(config.td3),
        actor_(D, A, config.td3),
        actor_target_(D, A, config.td3),
        critic_(D, A, config.td3.hidden, config.td3.activation, config.td3.twin),
        critic_target_(D, A, config.td3.hidden, config.td3.activation, config.td3.twin) {
    for (torch::nn::Module* m : std::initializer_list<torch::nn::Module*>{
             actor_.get(), actor_target_.get(), critic_.get(), critic_target_.get()})
      m->to(device);
    make_target(*actor_, *actor_target_);
    make_target(*critic_, *critic_target_);
    // on the device now: FlatAdam moves the parameters into its flat buffers (rl/flat_adam.h)
    actor_opt_ = std::make_unique<FlatAdam>(actor_->parameters(), c_.lr);
    critic_opt_ = std::make_unique<FlatAdam>(critic_->parameters(), c_.lr);
    steps_ = torch::zeros({1}, torch::kInt64);
    if (N > 0) replay_ = std::make_unique<ReplayBuffer>(c_.replay_size, D, A, device);
  }

  int steps_per_update() const override { return c_.horizon; }

  torch::Tensor act(const torch::Tensor& obs) override {
    torch::NoGradGuard ng;
    last_obs_ = obs;
    auto a = actor_->forward(obs);
    if (c_.act_noise > 0) a = (a + c_.act_noise * torch::randn_like(a)).clamp(-1, 1);
    last_act_ = a;
    return a;
  }

  void observe(const Transition& t) override {
    replay_->add(last_obs_, last_act_, t, c_.reward_scale);
  }

  std::vector<double> update(const torch::Tensor&) override {
    const auto dev = critic_->q1->parameters()[0].device();
    if (!sums_.defined() || sums_.device() != dev) {
      // q_loss, actor_loss, q_mean per critic step; the actor's saturated share per actor step
      sums_ = torch::zeros({3}, torch::TensorOptions().dtype(torch::kFloat64).device(dev));
      saturated_ = torch::zeros({}, sums_.options());
    }
    const int64_t step0 = steps_.item<int64_t>();  // a host tensor: no device read
    const int n = c_.epochs * c_.minibatches;
    int actor_steps = 0;
    for (int k = 0; k < n; ++k) actor_steps += td3_actor_step(step0 + k, c_.policy_delay);
    bool eager = true;
#ifdef BIDEX_TORCH_CUDA
    // a graph replays one fixed sequence: the buffer's size (the sampled range) and the phase
    // of the policy delay must be the same at every update
    if (c_.cuda_graph && dev.is_cuda() && replay_->size() == replay_->capacity() &&
        n % c_.policy_delay == 0) {
      eager = false;
      graphed_steps(n, step0);
    }
#endif
    if (eager) gradient_steps(n, step0);
    steps_.fill_(step0 + n);
    auto m = (sums_ / n).to(torch::kCPU);
    const double per_actor_step = actor_steps ? 1.0 / actor_steps : 0.0;
    return {m[0].item<double>(), m[1].item<double>() * n * per_actor_step, m[2].item<double>(),
            static_cast<double>(actor_steps), saturated_.item<double>() * per_actor_step};
  }

  // n gradient steps from gradient step step0, their statistics summed into sums_ and
  // saturated_; nothing read back, so that a CUDA graph can capture them
  void gradient_steps(int n, int64_t step0) {
    sums_.zero_();
    saturated_.zero_();
    for (int k = 0; k < n; ++k) {
      const auto b = replay_->sample(c_.batch_size);
      torch::Tensor target;
      {
        torch::NoGradGuard ng;
        auto mu = actor_target_->forward(b.next_obs);
        auto a_next = td3_target_action(mu, torch::randn_like(mu), c_.target_noise, c_.noise_clip);
        auto [q1n, q2n] = critic_target_->forward(b.next_obs, a_next);
        target = td3_q_target(b.rewards, b.terminal, q1n, q2n, c_.gamma);
      }
      auto [q1, q2] = critic_->forward(b.obs, b.actions);
      auto q_loss = (q1 - target).pow(2).mean();
      if (c_.twin) q_loss = 0.5 * (q_loss + (q2 - target).pow(2).mean());
      // Each optimiser's loss reaches every one of its parameters (DDPG has no q2), so that no
      // gradient is undefined at a step (FlatAdam would step it as zero where LibTorch's Adam
      // skipped it), and each zero_grad() comes before its loss's backward (the actor's loss
      // also reaches q1: the next critic step zeroes that first)
      critic_opt_->zero_grad();
      q_loss.backward();
      critic_opt_->clip_grad_norm(c_.max_grad_norm);
      critic_opt_->step();
      torch::Tensor actor_loss = torch::zeros({}, q_loss.options());
      if (td3_actor_step(step0 + k, c_.policy_delay)) {
        auto pre = actor_->preactivation(b.obs);
        auto mu_b = torch::tanh(pre);
        actor_loss = td3_actor_loss(critic_->forward(b.obs, mu_b).first, pre, c_.preact_l2);
        {
          torch::NoGradGuard ng;
          saturated_ += mu_b.detach().abs().gt(0.99).to(torch::kFloat64).mean();
        }
        actor_opt_->zero_grad();
        actor_loss.backward();
        actor_opt_->clip_grad_norm(c_.max_grad_norm);
        actor_opt_->step();
        polyak_update(*actor_, *actor_target_, c_.polyak);
        polyak_update(*critic_, *critic_target_, c_.polyak);
      }
      torch::NoGradGuard ng;
      sums_ += torch::stack({q_loss.detach(), actor_loss.detach(), q1.detach().mean()})
                   .to(torch::kFloat64);
    }
  }

#ifdef BIDEX_TORCH_CUDA
  // An update's gradient steps as one CUDA graph (rl/cuda_graph.h), captured anew where the
  // policy delay's phase differs from the graph's (a resumed run; n is a multiple of the delay)
  void graphed_steps(int n, int64_t step0) {
    const int64_t phase = step0 % c_.policy_delay;
    if (!graph_ || graph_phase_ != phase) {
      graph_ = std::make_unique<GraphedSteps>(
          c_.twin ? "TD3's gradient steps" : "DDPG's gradient steps",
          c_.twin ? "td3.cuda_graph" : "ddpg.cuda_graph");
      graph_phase_ = phase;
    }
    critic_opt_->rebind();
    actor_opt_->rebind();
    if (!graph_->run([&] { gradient_steps(n, step0); })) c_.cuda_graph = false;
  }
#endif

  const std::vector<std::string>& metric_names() const override {
    static const std::vector<std::string> names = {"q_loss", "actor_loss", "q_mean",
                                                   "actor_steps", "saturated"};
    return names;
  }

  void save(torch::serialize::OutputArchive& root) override {
    write_part(root, "actor", *actor_);
    write_part(root, "actor_target", *actor_target_);
    write_part(root, "critic", *critic_);
    write_part(root, "critic_target", *critic_target_);
    write_part(root, "actor_optimizer", *actor_opt_);
    write_part(root, "critic_optimizer", *critic_opt_);
    root.write("gradient_steps", steps_);
  }

  void load(torch::serialize::InputArchive& root, const std::string& path) override {
    read_checked(path, "does not fit this run's networks", [&] {
      read_module(root, "actor", *actor_, path, "this run's actor");
      read_module(root, "actor_target", *actor_target_, path, "this run's target actor");
      read_module(root, "critic", *critic_, path, "this run's critics");
      read_module(root, "critic_target", *critic_target_, path, "this run's target critics");
      read_optimizer(root, "actor_optimizer", *actor_opt_);
      read_optimizer(root, "critic_optimizer", *critic_opt_);
      torch::Tensor s;
      root.read("gradient_steps", s);
      steps_.copy_(s.to(torch::kCPU));
    });
  }

  void load_actor(torch::serialize::InputArchive& root, const std::string& path) override {
    read_checked(path, "holds no actor",
                 [&] { read_module(root, "actor", *actor_, path, "this run's actor"); });
  }

  torch::Tensor actor(const torch::Tensor& obs) override {
    torch::NoGradGuard ng;
    return actor_->forward(obs);
  }

 private:
  Td3Config c_;
  Td3Actor actor_, actor_target_;
  QCritic critic_, critic_target_;
  std::unique_ptr<FlatAdam> actor_opt_, critic_opt_;
  std::unique_ptr<ReplayBuffer> replay_;
  torch::Tensor steps_;  // gradient steps so far (the policy delay's phase; checkpointed)
  torch::Tensor last_obs_, last_act_;
  torch::Tensor sums_, saturated_;  // an update's statistics, summed on the device
#ifdef BIDEX_TORCH_CUDA
  std::unique_ptr<GraphedSteps> graph_;
  int64_t graph_phase_ = -1;  // the policy delay's phase the graph was captured at
#endif
};

}  // namespace

std::unique_ptr<Algorithm> make_td3(const TrainConfig& config, int64_t obs_dim, int64_t act_dim,
                                    int64_t nslot, const torch::Device& device) {
  return std::make_unique<Td3Algorithm>(config, obs_dim, act_dim, nslot, device);
}

}  // namespace bidex::rl
