// The learning core's algorithm interface. The runner (trainer.cc) owns the run
// folder, metrics, checkpoints, signals and resume; the collector (collector.h) steps the pack;
// an algorithm acts, stores what the steps gave, updates, and saves and loads its own state.
// algorithms.h is the registry of their names.
#pragma once

#include <functional>
#include <map>
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
  // Only from a collector in record mode (make_collector, datasets), else undefined:
  torch::Tensor truncated;  // [N] 1 where the time limit cut the episode and the slot did not fault
  torch::Tensor end_obs;    // [N, D] where done: the episode's last observation (other rows: any)
};

// Meta-RL's evaluation (bidex eval --split): the policy adapts to each slot's task from what it
// saw on it. The protocol (trainer.h, evaluate_meta) scores one episode of the meta-learned
// policy's deterministic action, begins afresh, explores for some episodes, adapts, and scores
// one episode of the adapted policy's deterministic action.
class Adaptive {
 public:
  virtual ~Adaptive() = default;
  // Starts from the meta-learned policy with nothing adapted or remembered: slot s belongs to
  // task slot_task[s] of ntasks (adaptation pools the slots of a task).
  virtual void begin(const std::vector<int>& slot_task, int ntasks) = 0;
  // Sampled actions [N, A] of the policy as adapted so far (exploration).
  virtual torch::Tensor explore(const torch::Tensor& obs) = 0;
  // Deterministic actions [N, A] in [-1, 1] of the policy as adapted so far.
  virtual torch::Tensor exploit(const torch::Tensor& obs) = 0;
  // The step that followed explore() or exploit(); `keep` [N] is 1 where the step belongs to
  // the slot's episodes of this phase and 0 where the slot is only waiting for the others.
  virtual void observe(const Transition& t, const torch::Tensor& keep) = 0;
  // Adapts each task from the steps kept since begin(): `steps` gradient steps (MAML, ProMP);
  // RL^2's memory adapts as it acts, and this does nothing.
  virtual void adapt(int steps) = 0;
  // Whether adapt() takes gradient steps (false: the adaptation is in memory, RL^2).
  virtual bool takes_steps() const { return true; }
};

class Algorithm {
 public:
  virtual ~Algorithm() = default;
  // Control steps of every slot collected before each update.
  virtual int steps_per_update() const = 0;
  // Actions [N, A] for observations [N, D] (sampled: exploration), on the training device; read
  // them before the next act(), which may reuse their memory (PPO returns its rollout's row).
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
  // Sampled actions [n, A] in [-1, 1] of the loaded actor, recording nothing (bidex collect
  // writes datasets with them); an algorithm without a sampling actor acts deterministically.
  virtual torch::Tensor sample_actor(const torch::Tensor& obs) { return actor(obs); }
  // The task of each slot of the training pack (taskpack::Pack::slot_tasks), given once before
  // the first act(); meta-RL adapts per task, other algorithms ignore it.
  virtual void set_slot_tasks(const std::vector<int>& /*slot_task*/, int /*ntasks*/) {}
  // Meta-RL's evaluation protocol, after load_actor(); null for algorithms that do not adapt.
  virtual Adaptive* adaptive() { return nullptr; }
  // What one update adds to the run's step count (the config's `steps`): the slot-steps it
  // collected (nslot x steps_per_update()), or an offline algorithm's gradient steps.
  virtual int64_t steps_counted(int64_t nslot) const { return nslot * steps_per_update(); }
  // Called by the runner once before training starts or resumes (never for evaluation or
  // rendering): an offline algorithm reads and checks its dataset (TrainConfig::dataset) here.
  virtual void prepare_training() {}
  // bidex train --profile: the learner times the stages of its update (rl/stage_timer.h),
  // waiting for the device at each; learner_profile() gives seconds per stage and the count of
  // its own host synchronisations ("host_syncs"), empty where an algorithm does not split.
  virtual void enable_profile() {}
  virtual std::map<std::string, double> learner_profile() const { return {}; }
};

using AlgorithmFactory = std::function<std::unique_ptr<Algorithm>(
    const TrainConfig& config, int64_t obs_dim, int64_t act_dim, int64_t nslot,
    const torch::Device& device)>;

// Adds an algorithm family's member from outside rl (metarl: MAML, ProMP, RL^2): its entry, its
// factory and the reader of its YAML section (algorithms.h). A name already registered is a
// std::logic_error. Families register once at start-up (the bidex command, tests).
void register_algorithm(const AlgorithmInfo& info, AlgorithmFactory make, SectionReader read);

// A new algorithm `name` (algorithms.h lists them) for a run of `nslot` slots of obs_dim /
// act_dim on `device`; an unknown name is a ConfigError listing the known ones.
std::unique_ptr<Algorithm> make_algorithm(const std::string& name, const TrainConfig& config,
                                          int64_t obs_dim, int64_t act_dim, int64_t nslot,
                                          const torch::Device& device);

}  // namespace bidex::rl
