// IQL (Kostrikov et al. 2021): V regresses an upper expectile of the target critics' min Q over
// the dataset's actions (never querying actions outside it), Q1 and Q2 regress
// r + not_done gamma V(s'), and the policy is fit by advantage-weighted regression, weights
// min(exp(beta (Q - V)), max_weight). Per step, as the original: V, then the critics with the
// updated V, the targets' Polyak step, then the policy.
//
// The expectile loss: the original writes mean(|expectile u^2 + relu(-u) u|), u = Q - V. For
// u >= 0 that is expectile u^2; for u < 0, relu(-u) u = -u^2 and |expectile u^2 - u^2| =
// (1 - expectile) u^2: exactly the standard asymmetric |expectile - 1(u < 0)| u^2, which
// losses.cc computes.
//
// The policy, as the original: an MLP whose mean head is tanh(linear), a state-independent
// log-variance, and the density of tanh of Normal(mean, exp(0.5 log_var)) at the dataset's
// actions clamped to +-0.99, per component. The mean is already squashed before the Tanh
// transform squashes again (double_tanh: true), so the Normal's mean fits atanh of the actions
// while acting uses tanh(linear) itself: the deterministic action is in the pre-squash space,
// which overshoots large actions (atanh(0.9) = 1.47 is fit by a mean that saturates at 1).
// double_tanh: false gives the consistent tanh-Gaussian: the Normal's mean is the linear head,
// whose tanh (the acting action, unchanged) is then the distribution's median.
//
// Departures: the policy's advantage uses the target critics before this step's Polyak update
// (computed once for V's loss; the original recomputes them after it, a 0.005 step away), and
// V(s) after V's step (as the original). One Adam over both critics equals the original's one
// per critic (Adam is per parameter and the two losses share none). Orthogonal weights of gain
// sqrt 2 everywhere, biases left at the default, as the original.
#include <cmath>

#include "offline/algorithms.h"
#include "offline/losses.h"
#include "rl/checkpoint.h"
#include "rl/policy.h"

namespace bidex::offline {

namespace {

struct IqlPolicyImpl : torch::nn::Module {
  IqlPolicyImpl(int64_t D, int64_t A, const std::vector<int>& hidden) {
    features = register_module("features", relu_trunk(D, hidden, std::sqrt(2.0)));
    torch::nn::Linear m(hidden.back(), A);
    torch::nn::init::orthogonal_(m->weight, std::sqrt(2.0));
    means = register_module("means", m);
    log_var = register_parameter("log_var", torch::zeros({A}));
  }
  // the linear head's output; acting takes its tanh
  torch::Tensor head(const torch::Tensor& nobs) { return means->forward(features->forward(nobs)); }
  torch::nn::Sequential features{nullptr};
  torch::nn::Linear means{nullptr};
  torch::Tensor log_var;
};
TORCH_MODULE(IqlPolicy);

class Iql final : public OfflineAlgorithm {
 public:
  Iql(const rl::TrainConfig& config, const IqlConfig& c, int64_t D, int64_t A,
      const torch::Device& device)
      : OfflineAlgorithm(config, c, D, A, device),
        c_(c),
        q_(twin_q(D, A, c.hidden, std::sqrt(2.0))),
        q_target_(twin_q(D, A, c.hidden, std::sqrt(2.0))),
        v_(relu_mlp(D, c.hidden, 1, std::sqrt(2.0))),
        policy_(D, A, c.hidden) {
    for (torch::nn::Module* m : std::initializer_list<torch::nn::Module*>{
             q_.get(), q_target_.get(), v_.get(), policy_.get()})
      m->to(device);
    rl::make_target(*q_, *q_target_);
    q_opt_ = std::make_unique<torch::optim::Adam>(q_->parameters(),
                                                  torch::optim::AdamOptions(c.q_lr));
    v_opt_ = std::make_unique<torch::optim::Adam>(v_->parameters(),
                                                  torch::optim::AdamOptions(c.v_lr));
    policy_opt_ = std::make_unique<torch::optim::Adam>(policy_->parameters(),
                                                       torch::optim::AdamOptions(c.policy_lr));
  }

  const std::vector<std::string>& metric_names() const override {
    static const std::vector<std::string> names = {"v_loss", "q_loss", "policy_loss",
                                                   "adv_mean"};
    return names;
  }

 protected:
  std::vector<torch::Tensor> train_step(const Batch& b, int64_t) override {
    const int64_t B = b.obs.size(0);
    torch::Tensor qt;
    {
      torch::NoGradGuard ng;
      const auto [t1, t2] = q_target_->forward(b.obs, b.actions);
      qt = torch::min(t1, t2);
    }
    auto v_loss = iql_expectile_loss(qt - v_->forward(b.obs).squeeze(1), c_.expectile);
    v_opt_->zero_grad();
    v_loss.backward();
    v_opt_->step();

    torch::Tensor v, target;
    {
      torch::NoGradGuard ng;
      // the updated V of both states in one pass
      const auto both = v_->forward(torch::cat({b.obs, b.next_obs}, 0)).squeeze(1);
      v = both.slice(0, 0, B);
      target = b.reward + c_.gamma * b.not_done * both.slice(0, B);
    }
    const auto [q1, q2] = q_->forward(b.obs, b.actions);
    auto q_loss = (q1 - target).pow(2).mean() + (q2 - target).pow(2).mean();
    q_opt_->zero_grad();
    q_loss.backward();
    q_opt_->step();
    rl::polyak_update(*q_, *q_target_, 1 - c_.tau);

    const auto w = iql_policy_weights(qt, v, c_.beta, c_.max_weight);
    auto mean = policy_->head(b.obs);
    if (c_.double_tanh) mean = torch::tanh(mean);
    const auto lp = iql_log_prob(b.actions.clamp(-0.99, 0.99), mean, policy_->log_var);
    auto policy_loss = iql_policy_loss(w, lp);
    policy_opt_->zero_grad();
    policy_loss.backward();
    policy_opt_->step();
    return {v_loss.detach(), q_loss.detach(), policy_loss.detach(), (qt - v).mean()};
  }

  torch::Tensor policy(const torch::Tensor& nobs) override {
    return torch::tanh(policy_->head(nobs));
  }

  void save_parts(torch::serialize::OutputArchive& root) override {
    rl::write_part(root, "policy", *policy_);
    rl::write_part(root, "q", *q_);
    rl::write_part(root, "q_target", *q_target_);
    rl::write_part(root, "v", *v_);
    rl::write_part(root, "policy_optimizer", *policy_opt_);
    rl::write_part(root, "q_optimizer", *q_opt_);
    rl::write_part(root, "v_optimizer", *v_opt_);
  }
  void load_parts(torch::serialize::InputArchive& root, const std::string& path) override {
    load_actor_parts(root, path);
    rl::read_module(root, "q", *q_, path, "this run's critics");
    rl::read_module(root, "q_target", *q_target_, path, "this run's target critics");
    rl::read_module(root, "v", *v_, path, "this run's value network");
    rl::read_optimizer(root, "policy_optimizer", *policy_opt_);
    rl::read_optimizer(root, "q_optimizer", *q_opt_);
    rl::read_optimizer(root, "v_optimizer", *v_opt_);
  }
  void load_actor_parts(torch::serialize::InputArchive& root, const std::string& path) override {
    rl::read_module(root, "policy", *policy_, path, "this run's policy");
  }

 private:
  IqlConfig c_;
  rl::QCritic q_, q_target_;
  torch::nn::Sequential v_;
  IqlPolicy policy_;
  std::unique_ptr<torch::optim::Adam> q_opt_, v_opt_, policy_opt_;
};

}  // namespace

std::unique_ptr<OfflineAlgorithm> make_iql(const rl::TrainConfig& config, int64_t obs_dim,
                                           int64_t act_dim, int64_t,
                                           const torch::Device& device) {
  return std::make_unique<Iql>(config, read_iql(section_of(config)), obs_dim, act_dim, device);
}

}  // namespace bidex::offline
