#include "core/progress.h"

#include <cstdio>

#include <unistd.h>

namespace bidex {

namespace {
std::string human(double v) {
  char buf[32];
  if (v >= 1e9) std::snprintf(buf, sizeof buf, "%.2fG", v / 1e9);
  else if (v >= 1e6) std::snprintf(buf, sizeof buf, "%.2fM", v / 1e6);
  else if (v >= 1e3) std::snprintf(buf, sizeof buf, "%.1fk", v / 1e3);
  else std::snprintf(buf, sizeof buf, "%.0f", v);
  return buf;
}

std::string clock(double s) {
  if (s < 0 || s > 1e7) return "--:--";
  char buf[32];
  int t = static_cast<int>(s + 0.5);
  if (t >= 3600) std::snprintf(buf, sizeof buf, "%d:%02d:%02d", t / 3600, t / 60 % 60, t % 60);
  else std::snprintf(buf, sizeof buf, "%02d:%02d", t / 60, t % 60);
  return buf;
}
}  // namespace

Progress::Progress(std::string label, int64_t total, std::string unit)
    : label_(std::move(label)), unit_(std::move(unit)), total_(total) {
  tty_ = ::isatty(STDERR_FILENO) != 0;
  start_ = last_draw_ = std::chrono::steady_clock::now();
}

Progress::~Progress() {
  if (!finished_) finish();
}

void Progress::update(int64_t done) {
  done_ = done;
  auto now = std::chrono::steady_clock::now();
  double since = std::chrono::duration<double>(now - last_draw_).count();
  if (since >= (tty_ ? 0.2 : 10.0)) {
    last_draw_ = now;
    draw(false);
  }
}

void Progress::finish() {
  if (finished_) return;
  finished_ = true;
  draw(true);
}

void Progress::draw(bool final) {
  double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  double rate = elapsed > 0 ? (done_ - baseline_) / elapsed : 0;
  double frac = total_ > 0 ? static_cast<double>(done_) / total_ : 0;
  double eta = rate > 0 ? (total_ - done_) / rate : -1;
  constexpr int kWidth = 28;
  int fill = static_cast<int>(frac * kWidth);
  std::string bar(fill, '#');
  bar.resize(kWidth, '.');
  std::fprintf(stderr, "%s%s [%s] %3.0f%% %s/%s %s %s/s elapsed %s eta %s%s%s%s",
               tty_ ? "\r" : "", label_.c_str(), bar.c_str(), frac * 100, human(done_).c_str(),
               human(total_).c_str(), unit_.c_str(), human(rate).c_str(), clock(elapsed).c_str(),
               clock(final ? 0 : eta).c_str(), status_.empty() ? "" : " | ", status_.c_str(),
               (final || !tty_) ? "\n" : (tty_ ? "\x1b[K" : ""));
  std::fflush(stderr);
}

}  // namespace bidex
