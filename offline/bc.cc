// BC: a deterministic tanh actor regressing the dataset's actions (mean squared error). The
// original Bi-DexHands code has no BC; its paper's table does. The actor and learning rate are
// TD3+BC's.
#include "offline/algorithms.h"
#include "offline/losses.h"
#include "rl/checkpoint.h"

namespace bidex::offline {

namespace {

class Bc final : public OfflineAlgorithm {
 public:
  Bc(const rl::TrainConfig& config, const BcConfig& c, int64_t D, int64_t A,
     const torch::Device& device)
      : OfflineAlgorithm(config, c, D, A, device), actor_(relu_mlp(D, c.hidden, A)) {
    actor_->to(device);
    opt_ = std::make_unique<torch::optim::Adam>(actor_->parameters(),
                                                torch::optim::AdamOptions(c.lr));
  }

  const std::vector<std::string>& metric_names() const override {
    static const std::vector<std::string> names = {"bc_mse"};
    return names;
  }

 protected:
  std::vector<torch::Tensor> train_step(const Batch& b, int64_t) override {
    auto loss = bc_loss(torch::tanh(actor_->forward(b.obs)), b.actions);
    opt_->zero_grad();
    loss.backward();
    opt_->step();
    return {loss.detach()};
  }

  torch::Tensor policy(const torch::Tensor& nobs) override {
    return torch::tanh(actor_->forward(nobs));
  }

  void save_parts(torch::serialize::OutputArchive& root) override {
    rl::write_part(root, "actor", *actor_);
    rl::write_part(root, "actor_optimizer", *opt_);
  }
  void load_parts(torch::serialize::InputArchive& root, const std::string& path) override {
    load_actor_parts(root, path);
    rl::read_optimizer(root, "actor_optimizer", *opt_);
  }
  void load_actor_parts(torch::serialize::InputArchive& root, const std::string& path) override {
    rl::read_module(root, "actor", *actor_, path, "this run's actor");
  }

 private:
  torch::nn::Sequential actor_;
  std::unique_ptr<torch::optim::Adam> opt_;
};

}  // namespace

std::unique_ptr<OfflineAlgorithm> make_bc(const rl::TrainConfig& config, int64_t obs_dim,
                                          int64_t act_dim, int64_t,
                                          const torch::Device& device) {
  return std::make_unique<Bc>(config, read_bc(section_of(config)), obs_dim, act_dim, device);
}

}  // namespace bidex::offline
