#include "marl/maddpg.h"

#include <string>

#include "core/error.h"
#include "marl/algorithms.h"
#include "rl/checkpoint.h"
#include "rl/policy.h"
#include "rl/td3.h"

namespace bidex::marl {

torch::Tensor maddpg_q_target(const torch::Tensor& reward, const torch::Tensor& terminal,
                              const torch::Tensor& q_next, double gamma) {
  return reward + gamma * (1 - terminal) * q_next;
}

torch::Tensor maddpg_joint_action(const AgentViews& views, const torch::Tensor& actions,
                                  int64_t i, const torch::Tensor& own) {
  std::vector<torch::Tensor> parts;
  for (int64_t j = 0; j < views.count(); ++j)
    parts.push_back(j == i ? own : views.actions(actions, j).detach());
  return views.assemble(parts);
}

Maddpg::Maddpg(const MaddpgConfig& config, const AgentSplit& split, int64_t nslot,
               const torch::Device& device)
    : c_(config), views_(split, device), device_(device) {
  const int64_t D = split.obs_dim, A = split.act_dim;
  for (int64_t i = 0; i < views_.count(); ++i) {
    actors_.emplace_back(views_.obs_dim(i), views_.act_dim(i), c_.net);
    actor_targets_.emplace_back(views_.obs_dim(i), views_.act_dim(i), c_.net);
    actor_list_->push_back(actors_.back());
    target_list_->push_back(actor_targets_.back());
  }
  critic_ = ValueNet(D + A, c_.net);
  critic_target_ = ValueNet(D + A, c_.net);
  actor_list_->to(device);
  target_list_->to(device);
  critic_->to(device);
  critic_target_->to(device);
  rl::make_target(*actor_list_, *target_list_);
  rl::make_target(*critic_, *critic_target_);
  for (auto& a : actors_)
    actor_opts_.push_back(std::make_unique<torch::optim::Adam>(
        a->parameters(), torch::optim::AdamOptions(c_.lr)));
  critic_opt_ = std::make_unique<torch::optim::Adam>(critic_->parameters(),
                                                     torch::optim::AdamOptions(c_.critic_lr));
  if (nslot > 0) replay_ = std::make_unique<rl::ReplayBuffer>(c_.replay_size, D, A, device);
}

torch::Tensor Maddpg::explore(const torch::Tensor& obs) {
  auto a = actor(obs);
  if (c_.expl_noise > 0) a = (a + c_.expl_noise * torch::randn_like(a)).clamp(-1, 1);
  return a;
}

torch::Tensor Maddpg::act(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  last_obs_ = obs;
  if (warming_up())  // uniform in [-1, 1], no actor
    last_act_ = torch::rand({obs.size(0), views_.split().act_dim}, obs.options()) * 2 - 1;
  else
    last_act_ = explore(obs);
  return last_act_;
}

void Maddpg::observe(const rl::Transition& t) {
  replay_->add(last_obs_, last_act_, t, c_.reward_scale);
  collected_ += last_obs_.size(0);
}

torch::Tensor Maddpg::q(const torch::Tensor& obs, const torch::Tensor& actions) {
  return critic_->forward(torch::cat({obs, actions}, -1));
}

torch::Tensor Maddpg::joint(std::vector<TanhActor>& actors, const torch::Tensor& obs) const {
  std::vector<torch::Tensor> parts;
  for (int64_t i = 0; i < views_.count(); ++i)
    parts.push_back(actors[i]->forward(views_.obs(obs, i)));
  return views_.assemble(parts);
}

torch::Tensor Maddpg::critic_target(const rl::ReplayBuffer::Batch& b) {
  torch::NoGradGuard ng;
  const auto a_next = joint(actor_targets_, b.next_obs);
  const auto q_next = critic_target_->forward(torch::cat({b.next_obs, a_next}, -1));
  return maddpg_q_target(b.rewards, b.terminal, q_next, c_.gamma);
}

std::pair<torch::Tensor, torch::Tensor> Maddpg::critic_step(const rl::ReplayBuffer::Batch& b) {
  const auto y = critic_target(b);
  const auto qv = q(b.obs, b.actions);
  const auto loss = value_error(qv - y, c_.huber_delta).mean();
  critic_opt_->zero_grad();
  loss.backward();
  torch::nn::utils::clip_grad_norm_(critic_->parameters(), c_.max_grad_norm);
  critic_opt_->step();
  return {loss.detach(), qv.detach().mean()};
}

torch::Tensor Maddpg::actor_step(int64_t i, const rl::ReplayBuffer::Batch& b) {
  const auto pre = actors_[i]->preact(views_.obs(b.obs, i));
  const auto joint = maddpg_joint_action(views_, b.actions, i, torch::tanh(pre));
  const auto loss = rl::td3_actor_loss(q(b.obs, joint), pre, c_.preact_l2);
  actor_opts_[i]->zero_grad();
  loss.backward();
  torch::nn::utils::clip_grad_norm_(actors_[i]->parameters(), c_.max_grad_norm);
  actor_opts_[i]->step();
  return loss.detach();
}

void Maddpg::update_targets() {
  rl::polyak_update(*actor_list_, *target_list_, 1.0 - c_.polyak);
  rl::polyak_update(*critic_, *critic_target_, 1.0 - c_.polyak);
}

std::vector<double> Maddpg::update(const torch::Tensor&) {
  const double stored = static_cast<double>(replay_->size());
  if (warming_up() || replay_->size() < c_.batch_size) return {0.0, 0.0, 0.0, stored};
  // critic loss and Q per critic step, actor loss per actor step, summed on the device
  auto sums = torch::zeros({3}, torch::TensorOptions().dtype(torch::kFloat64).device(device_));
  int64_t actor_steps = 0;
  for (int k = 0; k < c_.gradient_steps; ++k) {
    const auto b = replay_->sample(c_.batch_size);
    auto [critic_loss, q_mean] = critic_step(b);
    auto actor_loss = torch::zeros({}, critic_loss.options());
    if (++gradient_steps_ % c_.policy_freq == 0) {
      for (int64_t i = 0; i < views_.count(); ++i) actor_loss += actor_step(i, b);
      actor_steps += views_.count();
      update_targets();
    }
    sums += torch::stack({critic_loss, actor_loss, q_mean}).to(torch::kFloat64);
  }
  const auto m = sums.to(torch::kCPU);
  const double n = c_.gradient_steps;
  return {m[0].item<double>() / n,
          actor_steps ? m[1].item<double>() / static_cast<double>(actor_steps) : 0.0,
          m[2].item<double>() / n, stored};
}

const std::vector<std::string>& Maddpg::metric_names() const {
  static const std::vector<std::string> names = {"critic_loss", "actor_loss", "q_mean",
                                                 "replay_size"};
  return names;
}

torch::Tensor Maddpg::actor(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  return joint(actors_, obs);
}

torch::Tensor Maddpg::sample_actor(const torch::Tensor& obs) {
  torch::NoGradGuard ng;
  return explore(obs);
}

void Maddpg::save(torch::serialize::OutputArchive& root) {
  write_split(root, views_.split());
  rl::write_part(root, "actors", *actor_list_);
  rl::write_part(root, "actor_targets", *target_list_);
  rl::write_part(root, "critic", *critic_);
  rl::write_part(root, "critic_target", *critic_target_);
  rl::write_optimizers(root, "actor_optimizer_", actor_opts_);
  rl::write_part(root, "critic_optimizer", *critic_opt_);
  root.write("steps", torch::tensor({collected_, gradient_steps_}, torch::kInt64));
}

void Maddpg::load(torch::serialize::InputArchive& root, const std::string& path) {
  rl::read_checked(path, "does not fit this run's networks", [&] {
    check_split(root, views_.split(), path);
    rl::read_module(root, "actors", *actor_list_, path, "this run's actors");
    rl::read_module(root, "actor_targets", *target_list_, path, "this run's target actors");
    rl::read_module(root, "critic", *critic_, path, "this run's critic");
    rl::read_module(root, "critic_target", *critic_target_, path, "this run's target critic");
    rl::read_optimizers(root, "actor_optimizer_", actor_opts_);
    rl::read_optimizer(root, "critic_optimizer", *critic_opt_);
    torch::Tensor s;
    root.read("steps", s);
    s = s.to(torch::kCPU);
    collected_ = s[0].item<int64_t>();
    gradient_steps_ = s[1].item<int64_t>();
  });
}

void Maddpg::load_actor(torch::serialize::InputArchive& root, const std::string& path) {
  rl::read_checked(path, "holds no actors", [&] {
    check_split(root, views_.split(), path);
    rl::read_module(root, "actors", *actor_list_, path, "this run's actors");
  });
}

std::unique_ptr<rl::Algorithm> make_maddpg(const rl::TrainConfig& config, int64_t obs_dim,
                                           int64_t act_dim, int64_t nslot,
                                           const torch::Device& device) {
  const YamlView section = section_of(config);
  const MaddpgConfig c = read_maddpg(section);
  const AgentSplit split = run_agents(config, obs_dim, act_dim);
  const std::string key = config.algo + ".";
  if (nslot > 0 && c.replay_size < nslot)
    throw ConfigError(section.file(), key + "replay_size",
                      "at least env.slots (" + std::to_string(nslot) +
                          ") transitions, one step of every slot",
                      std::to_string(c.replay_size));
  if (c.batch_size > c.replay_size)
    throw ConfigError(section.file(), key + "batch_size",
                      "at most " + key + "replay_size (" + std::to_string(c.replay_size) + ")",
                      std::to_string(c.batch_size));
  return std::make_unique<Maddpg>(c, split, nslot, device);
}

}  // namespace bidex::marl
