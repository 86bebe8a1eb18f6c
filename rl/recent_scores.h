// A run's final score per pack entry: the episodes that ended in the entry's last few updates
// in which any of its episodes ended. Counting only such updates keeps entries whose episodes all
// end together (fixed lengths, no reset noise: the doors, switch, swing_cup in MT20's pack,
// where an episode ends every 30-40 updates) in the score, where the last few updates alone
// would often hold none of their episodes.
#pragma once

#include <cmath>
#include <deque>
#include <string>
#include <vector>

#include "rl/trainer.h"
#include "tasks/env.h"

namespace bidex::rl {

class RecentScores {
 public:
  explicit RecentScores(int updates) : keep_(updates) {}

  // One update's statistics, one per entry (the same entries every time).
  void add(const std::vector<tasks::EpisodeStats>& es) {
    if (window_.size() < es.size()) window_.resize(es.size());
    for (size_t g = 0; g < es.size(); ++g) {
      if (es[g].episodes == 0) continue;
      window_[g].push_back(es[g]);
      if (static_cast<int>(window_[g].size()) > keep_) window_[g].pop_front();
    }
  }

  // Entry g's score under its label and task id (mean return and success NaN without episodes).
  EntryScore score(size_t g, std::string label, std::string task) const {
    EntryScore e;
    e.label = std::move(label);
    e.task = std::move(task);
    double ret = 0, succ = 0;
    if (g < window_.size())
      for (auto& w : window_[g]) {
        e.episodes += w.episodes;
        ret += w.return_sum;
        succ += static_cast<double>(w.successes);
      }
    e.mean_return = e.episodes > 0 ? ret / e.episodes : NAN;
    e.success = e.episodes > 0 ? succ / e.episodes : NAN;
    return e;
  }

 private:
  int keep_;
  std::vector<std::deque<tasks::EpisodeStats>> window_;  // per entry, oldest first
};

}  // namespace bidex::rl
