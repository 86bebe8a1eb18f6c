// What BC, BCQ, TD3+BC and IQL share on the learning core: the dataset on the training device,
// uniform minibatches from it, the observation normaliser, the update loop and the common parts
// of checkpoints. An offline run's pack only evaluates: each update the runner restarts it and
// steps it one episode length with act() (the deterministic evaluation action, no exploration),
// observe() ignores the steps, and update() takes gradient_steps gradient steps on the dataset;
// the run's `steps` counts gradient steps (steps_counted).
//
// Observation normalisation (option obs_norm, on by default; our addition: TD3+BC's paper
// normalises states, the original Bi-DexHands runners feed them raw): observations are
// normalised by the dataset's per-component mean and std (over every stored observation row,
// std floored at 1e-3), computed in set_data and saved in checkpoints with the actor, so that
// evaluation and rendering (load_actor) act on the same inputs without the dataset.
#pragma once

#include <string>
#include <vector>

#include <torch/torch.h>

#include "offline/config.h"
#include "offline/dataset.h"
#include "offline/nets.h"
#include "rl/algorithm.h"

namespace bidex::offline {

class OfflineAlgorithm : public rl::Algorithm {
 public:
  // Builds nothing from the dataset: evaluation and rendering construct, load_actor and act.
  OfflineAlgorithm(const rl::TrainConfig& config, const OfflineConfig& common, int64_t obs_dim,
                   int64_t act_dim, const torch::Device& device);

  // unused: the runner evaluates one episode length per update (TrainsOn::kDataset)
  int steps_per_update() const final { return 1; }
  torch::Tensor act(const torch::Tensor& obs) final { return actor(obs); }
  void observe(const rl::Transition&) final {}
  std::vector<double> update(const torch::Tensor& obs) final;
  void save(torch::serialize::OutputArchive& root) final;
  void load(torch::serialize::InputArchive& root, const std::string& path) final;
  void load_actor(torch::serialize::InputArchive& root, const std::string& path) final;
  torch::Tensor actor(const torch::Tensor& obs) final;
  int64_t steps_counted(int64_t) const final { return common_.gradient_steps; }
  // load_transitions(config.dataset), then set_data.
  void prepare_training() final;

  // Checks that the dataset is of the run's task and widths (a DatasetError naming the dataset,
  // what was expected and what it holds) and uploads it to the training device (the normaliser
  // from its observations when obs_norm is on). Observations are kept once per episode row:
  // transition i goes from row obs_row[i] to row obs_row[i] + 1; only terminations end the
  // bootstrap (truncated episodes bootstrap from their last observation).
  void set_data(const Transitions& data);
  int64_t gradient_steps_done() const { return steps_; }

 protected:
  // A minibatch, observations normalised.
  struct Batch {
    torch::Tensor obs, actions, reward, not_done, next_obs;
  };
  // One gradient step (`step` counts them over the run from 0). Returns one detached scalar per
  // metric_names() entry, undefined where this step has no such value (TD3+BC's actor between
  // its delayed steps): update() averages each over the steps that gave it.
  virtual std::vector<torch::Tensor> train_step(const Batch& b, int64_t step) = 0;
  // The deterministic action [n, A] for normalised observations (under no_grad).
  virtual torch::Tensor policy(const torch::Tensor& nobs) = 0;
  // The algorithm's own checkpoint parts (networks, targets, optimisers); every part, or what
  // acting needs. Called inside rl::read_checked.
  virtual void save_parts(torch::serialize::OutputArchive& root) = 0;
  virtual void load_parts(torch::serialize::InputArchive& root, const std::string& path) = 0;
  virtual void load_actor_parts(torch::serialize::InputArchive& root,
                                const std::string& path) = 0;

  const torch::Device device_;
  const int64_t obs_dim_, act_dim_;

 private:
  Batch sample() const;

  OfflineConfig common_;
  std::string task_, dataset_;
  ObsNorm norm_;
  int64_t steps_ = 0;  // gradient steps so far (checkpointed)
  // the dataset on the device: observation rows (normalised), and per transition its action,
  // reward, 1 - termination and observation row
  torch::Tensor obs_rows_, actions_, reward_, not_done_, obs_row_;
};

}  // namespace bidex::offline
