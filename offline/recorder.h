// Steps of a pack turned into a dataset's episodes (bidex collect, bidex train --record-replay):
// each recorded slot's steps stay on the host until its episode ends, and are then written whole
// (observations T+1 rows, the applied actions clamped to [-1, 1], rewards, terminations and
// truncations), so a dataset never holds a cut episode.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <torch/torch.h>

#include "offline/dataset.h"
#include "rl/algorithm.h"
#include "rl/trainer.h"

namespace bidex::taskpack {
class Pack;
}

namespace bidex::offline {

class EpisodeRecorder {
 public:
  // Records the pack slots `slots` (ascending, each < nslot) into `writer` until at least
  // `max_steps` transitions are written.
  EpisodeRecorder(DatasetWriter& writer, std::vector<int64_t> slots, int64_t obs_dim,
                  int64_t act_dim, int64_t max_steps);
  // The observations [N, D] after the pack's reset: every recorded slot starts an episode.
  void begin(const torch::Tensor& obs);
  // One step: the actions [N, A] chosen and what the step gave (a collector in record mode).
  void step(const torch::Tensor& actions, const rl::Transition& t);
  bool full() const { return writer_.steps() >= max_steps_; }
  // The mean return of the episodes written so far (NaN: none).
  double mean_return() const;

 private:
  struct Episode {
    std::vector<float> obs, actions, rewards;
    std::vector<uint8_t> term, trunc;
  };
  DatasetWriter& writer_;
  torch::Tensor index_;  // the recorded slots, long, on the pack's rows' device
  std::vector<Episode> open_;
  int64_t D_, A_, max_steps_;
  double return_sum_ = 0;
  int64_t returns_ = 0;
};

// --record-replay: the first `steps` transitions of a training run's stream become the replay
// dataset at `dir` (quality replay). They come from a share of its slots (spread evenly, at least
// one) chosen so that `steps` are reached about halfway through a run of `config.steps`
// slot-steps: the original's replay data were its collection run's first half.
rl::RecorderFactory replay_recorder(const std::string& dir, int64_t steps,
                                    const std::string& command);

// The slots a recorder keeps: `count` of `nslot`, spread evenly.
std::vector<int64_t> spread_slots(int64_t nslot, int64_t count);

// A dataset's metadata for `task` as the pack `pack` runs it (id, widths, time limit, code
// version): the common part of what collect and the replay recorder write.
DatasetInfo task_info(const taskpack::Pack& pack, const std::string& quality);

}  // namespace bidex::offline
