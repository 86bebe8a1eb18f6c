#include "metarl/rl2.h"

#include <stdexcept>

#include "rl/policy.h"
#include "rl/ppo.h"

namespace bidex::metarl {

Rl2::Rl2(int64_t obs_dim, int64_t act_dim, int64_t nslot, const Rl2Config& config,
         const torch::Device& device)
    : c_(config),
      nslot_(nslot),
      policy_(obs_dim, act_dim, config.hidden_size, config.init_std, config.input_norm),
      scale_(nslot, config.gamma, device) {
  if (nslot < c_.minibatches)
    throw std::invalid_argument("RL^2: " + std::to_string(nslot) + " slots cannot make " +
                                std::to_string(c_.minibatches) + " minibatches of whole slots");
  if (c_.trial_episodes < 1) throw std::invalid_argument("RL^2: trial_episodes must be >= 1");
  policy_->to(device);
  opt_ = std::make_unique<torch::optim::Adam>(policy_->parameters(),
                                              torch::optim::AdamOptions(c_.lr));
  const auto f = torch::TensorOptions().dtype(torch::kFloat32).device(device);
  const int64_t T = c_.horizon, N = nslot, A = act_dim;
  hidden_ = policy_->initial_hidden(N);
  prev_action_ = torch::zeros({N, A}, f);
  prev_reward_ = torch::zeros({N}, f);
  prev_done_ = torch::zeros({N}, f);
  episodes_ = torch::zeros({N}, f);
  new_trial_ = torch::zeros({N}, f);
  inputs_ = torch::zeros({T, N, policy_->input_dim()}, f);
  actions_ = torch::zeros({T, N, A}, f);
  means_ = torch::zeros({T, N, A}, f);
  logp_ = torch::zeros({T, N}, f);
  values_ = torch::zeros({T, N}, f);
  rewards_ = torch::zeros({T, N}, f);
  cuts_ = torch::zeros({T, N}, f);
  resets_ = torch::zeros({T, N}, f);
}

torch::Tensor Rl2::act(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  if (t_ == 0) hidden0_ = hidden_.clone();
  // a new trial: its first step sees no previous action, reward or done, and no memory
  const auto keep = 1 - new_trial_;
  hidden_ = hidden_ * keep.view({1, -1, 1});
  prev_action_ = prev_action_ * keep.unsqueeze(1);
  prev_reward_ = prev_reward_ * keep;
  prev_done_ = prev_done_ * keep;
  resets_[t_] = new_trial_;
  new_trial_.zero_();
  policy_->update_input_norm(obs);
  const auto input = policy_->input(obs, prev_action_, prev_reward_, prev_done_);
  auto [mean, value, h] = policy_->forward_step(input, hidden_);
  const auto a = mean + policy_->log_std().exp() * torch::randn_like(mean);
  inputs_[t_] = input;
  actions_[t_] = a;
  means_[t_] = mean;
  logp_[t_] = rl::gaussian_log_prob(a, mean, policy_->log_std());
  values_[t_] = value;
  hidden_ = h;
  prev_action_ = a.clamp(-1, 1);  // what the pack applies
  return a;
}

void Rl2::observe(const torch::Tensor& reward, const torch::Tensor& done) {
  if (t_ >= c_.horizon) throw std::logic_error("RL^2: more steps than the horizon before update");
  const auto d = done.to(torch::kFloat32);
  rewards_[t_] = c_.task_reward_norm ? scale_.scaled(reward, d) : reward;
  prev_reward_ = reward.to(torch::kFloat32);
  prev_done_ = d;
  episodes_ += d;
  new_trial_ = (episodes_ >= c_.trial_episodes).to(torch::kFloat32);
  episodes_ *= 1 - new_trial_;
  cuts_[t_] = new_trial_;
  ++t_;
}

std::vector<double> Rl2::update(const torch::Tensor& obs) {
  torch::AutoGradMode grad_on(true);  // also when the caller holds a NoGradGuard
  if (t_ != c_.horizon)
    throw std::logic_error("RL^2: update after " + std::to_string(t_) + " of " +
                           std::to_string(c_.horizon) + " steps");
  torch::Tensor last_value;
  {
    torch::NoGradGuard ng;
    const auto input = policy_->input(obs, prev_action_, prev_reward_, prev_done_);
    last_value = std::get<1>(policy_->forward_step(input, hidden_));
  }
  // the trial's return: the recursion runs over episode ends and stops at trial ends
  auto [adv, ret] = rl::gae(rewards_, values_, cuts_, last_value, c_.gamma, c_.lambda);
  adv = (adv - adv.mean()) / (adv.std() + 1e-8);
  const auto log_std_old = policy_->log_std().detach().clone();
  const int64_t per = nslot_ / c_.minibatches;
  auto sums = torch::zeros({4}, torch::TensorOptions().dtype(torch::kFloat64)
                                    .device(rewards_.device()));
  int n = 0;
  for (int e = 0; e < c_.epochs; ++e) {
    const auto perm = torch::randperm(nslot_, torch::TensorOptions().dtype(torch::kLong)
                                                  .device(rewards_.device()));
    for (int m = 0; m < c_.minibatches; ++m) {
      const auto idx = perm.slice(0, m * per, (m + 1) * per);
      const auto out =
          policy_->forward_sequence(inputs_.index_select(1, idx), hidden0_.index_select(1, idx),
                                    resets_.index_select(1, idx));
      const auto& mean = std::get<0>(out);
      const auto& value = std::get<1>(out);
      const auto logp = rl::gaussian_log_prob(actions_.index_select(1, idx), mean,
                                              policy_->log_std());
      const auto ratio = (logp - logp_.index_select(1, idx)).exp();
      const auto a = adv.index_select(1, idx);
      const auto policy_loss = rl::clipped_surrogate(ratio, a, c_.clip);
      const auto value_loss = (value - ret.index_select(1, idx)).pow(2).mean();
      const auto entropy = rl::gaussian_entropy(policy_->log_std());
      const auto loss = policy_loss + c_.value_coef * value_loss - c_.entropy_coef * entropy;
      opt_->zero_grad();
      loss.backward();
      torch::nn::utils::clip_grad_norm_(policy_->parameters(), c_.max_grad_norm);
      opt_->step();
      torch::NoGradGuard ng;
      const auto kl = rl::gaussian_kl(means_.index_select(1, idx), log_std_old, mean,
                                      policy_->log_std())
                          .mean();
      sums += torch::stack({policy_loss.detach(), value_loss.detach(), entropy.detach(), kl})
                  .to(torch::kFloat64);
      ++n;
    }
  }
  t_ = 0;
  const auto m = (sums / n).to(torch::kCPU);
  return {m[0].item<double>(), m[1].item<double>(), m[2].item<double>(), m[3].item<double>()};
}

}  // namespace bidex::metarl
