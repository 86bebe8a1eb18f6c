// The learning core's algorithm interface. The runner (trainer.cc) owns the run
// folder, metrics, checkpoints, signals and resume; the collector (collector.h) steps the pack;
// an algorithm acts, stores what the steps gave, updates, and saves and loads its own state.
// algorithms.h is the registry of their names.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <torch/torch.h>

#include "rl/algorithms.h"
#include "rl/config.h"

namespace bidex::rl {

// What one control step of every slot gave, on the training device (collector.h).
struct Transition {
  torch::Tensor obs;        // [N, D] after the step (a finished slot's row is its reset state)
  torch::Tensor reward;     // [N] (the pack's scaled reward)
  torch::Tensor done;       // [N] 1 where the episode ended at this step, either way
  torch::Tensor final_ids;  // [K] long: slots whose episode the time limit cut (not faulted)
  torch::Tensor final_obs;  // [K, D] their last observation, for bootstrapping
};

class Algorithm {
 public:
  virtual ~Algorithm() = default;
  // Control steps of every slot collected before each update.
  virtual int steps_per_update() const = 0;
  // Actions [N, A] for observations [N, D] (sampled: exploration), on the training device.
  virtual torch::Tensor act(const torch::Tensor& obs) = 0;
  // The step that followed the last act().
  virtual void observe(const Transition& t) = 0;
  // The update after steps_per_update() steps; `obs` are the observations after the last one.
  // Returns one value per metric_names() entry.
  virtual std::vector<double> update(const torch::Tensor& obs) = 0;
  virtual const std::vector<std::string>& metric_names() const = 0;
  // Everything a resumed run needs (networks, normalisers, optimiser state, schedules).
  virtual void save(torch::serialize::OutputArchive& root) = 0;
  virtual void load(torch::serialize::InputArchive& root, const std::string& path) = 0;
  // Only what acting needs, for evaluation and rendering (`path` names the file in errors).
  virtual void load_actor(torch::serialize::InputArchive& root, const std::string& path) = 0;
  // The deterministic actions [n, A] in [-1, 1] for observations [n, D] (evaluation, render).
  virtual torch::Tensor actor(const torch::Tensor& obs) = 0;
};

// A new algorithm `name` (algorithms.h lists them) for a run of `nslot` slots of obs_dim /
// act_dim on `device`; an unknown name is a ConfigError listing the known ones.
std::unique_ptr<Algorithm> make_algorithm(const std::string& name, const TrainConfig& config,
                                          int64_t obs_dim, int64_t act_dim, int64_t nslot,
                                          const torch::Device& device);

}  // namespace bidex::rl
