// A one-line progress bar on stderr with rate and ETA, for long commands (benchmarks, soaks,
// training). Redraws at most a few times per second; prints plain lines when stderr is no TTY.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace bidex {

class Progress {
 public:
  // `total` units of work named `unit` (e.g. "slot-steps"); `label` prefixes the line.
  Progress(std::string label, int64_t total, std::string unit);
  ~Progress();

  // Marks `done` units as finished (absolute count) and redraws if due.
  void update(int64_t done);
  // Text drawn after the rate and ETA (e.g. "return 12.3 success 0.40"); empty: none.
  void set_status(std::string status) { status_ = std::move(status); }
  // Work already done before this bar started (a resumed run): counted in the fraction, not in
  // the rate.
  void set_baseline(int64_t done) { baseline_ = done_ = done; }
  // Draws the final line and a newline.
  void finish();

 private:
  void draw(bool final);

  std::string label_, unit_, status_;
  int64_t total_ = 0, done_ = 0, baseline_ = 0;
  bool tty_ = false, finished_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace bidex
