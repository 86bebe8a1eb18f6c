// RL^2 on the learning core: the Rl2 learner (rl2.h) behind rl::Algorithm, and its evaluation,
// where adapting is acting with memory: the exploration episodes fill the GRU's state and the
// scored episode goes on from it.
#include "metarl/algorithms.h"
#include "metarl/config.h"
#include "metarl/recurrent_policy.h"
#include "metarl/rl2.h"
#include "rl/checkpoint.h"
#include "rl/policy.h"

namespace bidex::metarl {

namespace {

class Rl2Algorithm final : public rl::Algorithm, public rl::Adaptive {
 public:
  Rl2Algorithm(const Rl2Config& c, int64_t D, int64_t A, int64_t N, const torch::Device& device)
      : c_(c), A_(A) {
    if (N > 0) {
      learner_ = std::make_unique<Rl2>(D, A, N, c, device);
      policy_ = learner_->policy();
    } else {  // acting only (evaluation, render)
      policy_ = RecurrentPolicy(D, A, c.hidden_size, c.init_std, c.input_norm);
      policy_->to(device);
    }
  }

  int steps_per_update() const override { return c_.horizon; }
  void set_slot_tasks(const std::vector<int>& slot_task, int ntasks) override {
    if (learner_) learner_->set_slot_tasks(slot_task, ntasks);
  }
  torch::Tensor act(const torch::Tensor& obs) override { return learner_->act(obs); }
  void observe(const rl::Transition& t) override { learner_->observe(t.reward, t.done); }
  std::vector<double> update(const torch::Tensor& obs) override { return learner_->update(obs); }

  const std::vector<std::string>& metric_names() const override {
    static const std::vector<std::string> names = {"policy_loss", "value_loss", "entropy", "kl"};
    return names;
  }

  void save(torch::serialize::OutputArchive& root) override {
    rl::write_part(root, "recurrent_policy", *policy_);
    rl::write_part(root, "optimizer", learner_->optimizer());
    if (c_.task_reward_norm) learner_->reward_scale().save(root);
  }

  void load(torch::serialize::InputArchive& root, const std::string& path) override {
    rl::read_checked(path, "does not fit this run's networks", [&] {
      rl::read_module(root, "recurrent_policy", *policy_, path, "this run's recurrent policy");
      rl::read_optimizer(root, "optimizer", learner_->optimizer());
      if (c_.task_reward_norm) learner_->reward_scale().load(root);
    });
  }

  void load_actor(torch::serialize::InputArchive& root, const std::string& path) override {
    rl::read_checked(path, "holds no recurrent policy", [&] {
      rl::read_module(root, "recurrent_policy", *policy_, path, "this run's recurrent policy");
    });
  }

  // Without memory: the policy at a task's first step (render, plain evaluation).
  torch::Tensor actor(const torch::Tensor& obs) override {
    torch::NoGradGuard ng;
    const int64_t n = obs.size(0);
    const auto f = obs.options();
    const auto input = policy_->input(obs, torch::zeros({n, A_}, f), torch::zeros({n}, f),
                                      torch::zeros({n}, f));
    return std::get<0>(policy_->forward_step(input, policy_->initial_hidden(n))).clamp(-1, 1);
  }

  rl::Adaptive* adaptive() override { return this; }

  // --- evaluation (rl::Adaptive): one memory per slot, from begin() on ---
  void begin(const std::vector<int>& slot_task, int) override {
    const int64_t n = static_cast<int64_t>(slot_task.size());
    hidden_ = policy_->initial_hidden(n);
    const auto f = hidden_.options();
    prev_action_ = torch::zeros({n, A_}, f);
    prev_reward_ = torch::zeros({n}, f);
    prev_done_ = torch::zeros({n}, f);
  }

  torch::Tensor explore(const torch::Tensor& obs) override { return step(obs, true); }
  torch::Tensor exploit(const torch::Tensor& obs) override { return step(obs, false); }

  void observe(const rl::Transition& t, const torch::Tensor& keep) override {
    // a slot that only waits for the others keeps its memory as it was
    const auto k = keep.to(hidden_.options());
    hidden_ = torch::lerp(hidden_, next_hidden_, k.view({1, -1, 1}));
    prev_action_ = torch::lerp(prev_action_, last_action_, k.unsqueeze(1));
    prev_reward_ = torch::lerp(prev_reward_, t.reward.to(k.options()), k);
    prev_done_ = torch::lerp(prev_done_, t.done.to(k.options()), k);
  }

  void adapt(int) override {}
  bool takes_steps() const override { return false; }

 private:
  torch::Tensor step(const torch::Tensor& obs, bool sample) {
    torch::NoGradGuard ng;
    const auto input = policy_->input(obs, prev_action_, prev_reward_, prev_done_);
    auto [mean, value, h] = policy_->forward_step(input, hidden_);
    next_hidden_ = h;
    auto a = sample ? mean + policy_->log_std().exp() * torch::randn_like(mean) : mean;
    last_action_ = a.clamp(-1, 1);
    return sample ? a : last_action_;
  }

  Rl2Config c_;
  int64_t A_;
  std::unique_ptr<Rl2> learner_;
  RecurrentPolicy policy_{nullptr};
  torch::Tensor hidden_, next_hidden_, prev_action_, prev_reward_, prev_done_, last_action_;
};

}  // namespace

std::unique_ptr<rl::Algorithm> make_rl2(const rl::TrainConfig& config, int64_t obs_dim,
                                        int64_t act_dim, int64_t nslot,
                                        const torch::Device& device) {
  const auto section = YamlView::load_string(config.section_yaml, "rl2 section");
  return std::make_unique<Rl2Algorithm>(read_rl2(section), obs_dim, act_dim, nslot, device);
}

}  // namespace bidex::metarl
