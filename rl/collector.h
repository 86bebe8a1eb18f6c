// The collector: steps a pack with the actions an algorithm chose and hands back what the step
// gave on the training device (rl/algorithm.h Transition).
//   - A CPU pack (taskpack::TaskPack): one transfer each way per step (with CUDA, from pinned
//     host memory): the actions to the host, then one buffer of observations, rewards, done
//     flags and the final observations of slots whose episode the time limit cut.
//   - A GPU pack (taskpack::WarpPack): nothing crosses to the host. The pack's action rows, and
//     its observation, reward and flag rows, are tensors over its device memory; the collector
//     copies the actions in, waits for them, steps the pack and copies its rows out on the
//     device.
#pragma once

#include <memory>

#include <torch/torch.h>

#include "rl/algorithm.h"

namespace bidex::taskpack {
class Pack;
}

namespace bidex::rl {

class Collector {
 public:
  virtual ~Collector() = default;
  // Resets every slot; the observations [N, D].
  virtual torch::Tensor reset() = 0;
  // One control step of every slot with `actions` [N, A] (any device).
  virtual Transition step(const torch::Tensor& actions) = 0;
  // Seconds spent inside the pack's step since the last call (what simulation costs).
  double take_sim_seconds();
  // Ends record mode (make_collector): the recorder has what it wanted, and the steps after it
  // copy no more than training needs.
  void stop_recording() { record_ = false; }

 protected:
  explicit Collector(bool record) : record_(record) {}
  double sim_s_ = 0;
  bool record_;
};

// The collector of a CPU or GPU pack for a learner on `device`. A GPU pack needs its learner on
// the same device (an Error otherwise). With `record`, each Transition also has `truncated` and
// `end_obs` (what a dataset's episodes need; a CPU pack then copies every row of final
// observations each step).
std::unique_ptr<Collector> make_collector(taskpack::Pack& pack, const torch::Device& device,
                                          bool record = false);

}  // namespace bidex::rl
