// The metrics of a run: one row per update, written to <run>/metrics.csv and <run>/metrics.jsonl
// as it comes (a line each, flushed), and drawn as <run>/learning_curve.svg. A resumed run keeps
// the rows up to its checkpoint; rows written after it are saved aside, never silently dropped.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace bidex::rl {

class MetricsLog {
 public:
  // A new log in `dir` with these columns (the first must be "update").
  MetricsLog(std::string dir, std::vector<std::string> columns);
  // Reopens the log of `dir` for a run resumed after update `update`: rows after it are moved to
  // metrics.after_update_<update>.csv. The header must match `columns`.
  static MetricsLog resume(std::string dir, std::vector<std::string> columns, int64_t update);
  ~MetricsLog();
  MetricsLog(MetricsLog&&) noexcept;
  MetricsLog(const MetricsLog&) = delete;
  MetricsLog& operator=(const MetricsLog&) = delete;

  // One row, in column order; NaN is written as an empty CSV cell and a JSON null.
  void append(const std::vector<double>& row);
  const std::vector<std::string>& columns() const { return columns_; }
  const std::vector<std::vector<double>>& rows() const { return rows_; }
  // A column by name (NaN where missing); throws std::out_of_range for an unknown name.
  std::vector<double> column(const std::string& name) const;
  // Writes learning_curve.svg (mean return, success rate and episode length against slot-steps,
  // and for a suite run one line per task from the return_<label> columns) atomically; `title`
  // heads the first panel.
  void plot(const std::string& title) const;

 private:
  MetricsLog() = default;
  void open_append();
  std::string dir_;
  std::vector<std::string> columns_;
  std::vector<std::vector<double>> rows_;
  std::FILE* csv_ = nullptr;
  std::FILE* jsonl_ = nullptr;
};

// Parses a metrics.csv text (header + rows; empty cells are NaN).
void parse_metrics_csv(const std::string& text, const std::string& name,
                       std::vector<std::string>& columns, std::vector<std::vector<double>>& rows);

}  // namespace bidex::rl
