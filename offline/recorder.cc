#include "offline/recorder.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <dirent.h>
#include <unistd.h>

#include "core/version.h"
#include "taskpack/pack.h"
#include "tasks/spec.h"

namespace bidex::offline {

std::vector<int64_t> spread_slots(int64_t nslot, int64_t count) {
  count = std::clamp<int64_t>(count, 1, nslot);
  std::vector<int64_t> out(count);
  for (int64_t i = 0; i < count; ++i) out[i] = i * nslot / count;
  return out;
}

EpisodeRecorder::EpisodeRecorder(DatasetWriter& writer, std::vector<int64_t> slots,
                                 int64_t obs_dim, int64_t act_dim, int64_t max_steps)
    : writer_(writer), open_(slots.size()), D_(obs_dim), A_(act_dim), max_steps_(max_steps) {
  index_ = torch::tensor(slots, torch::kLong);
}

void EpisodeRecorder::begin(const torch::Tensor& obs) {
  index_ = index_.to(obs.device());
  auto rows = obs.index_select(0, index_).to(torch::kCPU).contiguous();
  const float* o = rows.data_ptr<float>();
  for (size_t j = 0; j < open_.size(); ++j) {
    open_[j] = Episode();
    open_[j].obs.assign(o + j * D_, o + (j + 1) * D_);
  }
}

void EpisodeRecorder::step(const torch::Tensor& actions, const rl::Transition& t) {
  if (full()) return;
  // one transfer of the recorded rows: [actions A | obs D | end obs D | reward | done | trunc]
  auto rows = torch::cat({actions.to(t.obs.device()).index_select(0, index_).clamp(-1.0, 1.0),
                          t.obs.index_select(0, index_), t.end_obs.index_select(0, index_),
                          t.reward.index_select(0, index_).unsqueeze(1),
                          t.done.index_select(0, index_).unsqueeze(1),
                          t.truncated.index_select(0, index_).unsqueeze(1)},
                         1)
                  .to(torch::kCPU)
                  .contiguous();
  const int64_t W = A_ + 2 * D_ + 3;
  const float* base = rows.data_ptr<float>();
  for (size_t j = 0; j < open_.size(); ++j) {
    const float* r = base + j * W;
    const float *act = r, *next = r + A_, *end = r + A_ + D_;
    const float reward = r[A_ + 2 * D_], done = r[A_ + 2 * D_ + 1], trunc = r[A_ + 2 * D_ + 2];
    Episode& e = open_[j];
    e.actions.insert(e.actions.end(), act, act + A_);
    e.rewards.push_back(reward);
    if (done == 0.f) {
      e.term.push_back(0);
      e.trunc.push_back(0);
      e.obs.insert(e.obs.end(), next, next + D_);
      continue;
    }
    e.term.push_back(trunc == 0.f ? 1 : 0);
    e.trunc.push_back(trunc == 0.f ? 0 : 1);
    e.obs.insert(e.obs.end(), end, end + D_);
    const int64_t T = static_cast<int64_t>(e.rewards.size());
    if (!full() && writer_.add_episode(e.obs.data(), e.actions.data(), e.rewards.data(),
                                       e.term.data(), e.trunc.data(), T)) {
      double ret = 0;
      for (float x : e.rewards) ret += x;
      return_sum_ += ret;
      returns_ += 1;
    }
    e = Episode();  // the slot's next episode starts from its reset observation
    e.obs.assign(next, next + D_);
  }
}

double EpisodeRecorder::mean_return() const {
  return returns_ ? return_sum_ / static_cast<double>(returns_) : NAN;
}

DatasetInfo task_info(const taskpack::Pack& pack, const std::string& quality) {
  const tasks::TaskSpec& spec = pack.task_spec(0);
  DatasetInfo info;
  info.task = spec.id;
  info.task_version = spec.versioned_id();
  info.quality = quality;
  info.dataset_id = spec.id + "/" + quality + "-v0";
  info.obs_dim = pack.obs_dim();
  info.act_dim = pack.act_dim();
  info.max_episode_steps = spec.episode_length;
  info.code_version = code_version();
  return info;
}

namespace {

class ReplayRecorder : public rl::StepRecorder {
 public:
  ReplayRecorder(const rl::TrainConfig& c, const taskpack::Pack& pack, const std::string& dir,
                 int64_t steps, const std::string& command) {
    DatasetInfo info = task_info(pack, "replay");
    info.policy = "the training stream of the run";
    info.algorithm_name = c.algo;
    info.seed = c.seed;
    info.command = command;
    writer_ = std::make_unique<DatasetWriter>(dir, info);
    const double share = std::min(1.0, 2.0 * static_cast<double>(steps) / double(c.steps));
    const int64_t n = pack.nslot();
    rec_ = std::make_unique<EpisodeRecorder>(
        *writer_, spread_slots(n, static_cast<int64_t>(std::ceil(share * double(n)))),
        pack.obs_dim(), pack.act_dim(), steps);
  }
  void begin(const torch::Tensor& obs) override { rec_->begin(obs); }
  bool step(const torch::Tensor& actions, const rl::Transition& t) override {
    rec_->step(actions, t);
    return !rec_->full();
  }
  void finish() override {
    if (!writer_) return;
    if (writer_->episodes() > 0) writer_->finish();
    writer_.reset();
  }

 private:
  std::unique_ptr<DatasetWriter> writer_;
  std::unique_ptr<EpisodeRecorder> rec_;
};

}  // namespace

rl::RecorderFactory replay_recorder(const std::string& dir, int64_t steps,
                                    const std::string& command) {
  // checked now, not when the run's loop makes the writer: by then the run folder and its
  // registry row exist, and a taken destination would leave them half-made
  if (DIR* d = ::opendir(dir.c_str())) {
    bool empty = true;
    while (const dirent* e = ::readdir(d))
      if (std::strcmp(e->d_name, ".") != 0 && std::strcmp(e->d_name, "..") != 0) empty = false;
    ::closedir(d);
    if (!empty)
      throw DatasetError(dir + ": already exists and is not an empty folder (nothing there was "
                         "touched)");
  } else if (::access(dir.c_str(), F_OK) == 0) {
    throw DatasetError(dir + ": already exists and is not an empty folder (nothing there was "
                       "touched)");
  }
  return [=](const rl::TrainConfig& c, const taskpack::Pack& pack) {
    if (pack.ngroups() != 1 || !c.suite.empty())
      throw Error("--record-replay records a task run's stream; " + c.target() +
                  " is a suite (datasets are of one task)");
    return std::unique_ptr<rl::StepRecorder>(
        std::make_unique<ReplayRecorder>(c, pack, dir, steps, command));
  };
}

}  // namespace bidex::offline
