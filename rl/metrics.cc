#include "rl/metrics.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/error.h"
#include "core/files.h"
#include "core/plot.h"

namespace bidex::rl {

namespace {

std::string cell(double v) {
  if (!std::isfinite(v)) return "";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string csv_line(const std::vector<double>& row) {
  std::string s;
  for (size_t i = 0; i < row.size(); ++i) {
    if (i) s.append(",");
    s.append(cell(row[i]));
  }
  s.append("\n");
  return s;
}

std::string json_line(const std::vector<std::string>& cols, const std::vector<double>& row) {
  std::string s = "{";
  for (size_t i = 0; i < cols.size(); ++i) {
    const std::string v = cell(row[i]);
    s.append(i ? ",\"" : "\"").append(cols[i]).append("\":").append(v.empty() ? "null" : v);
  }
  s.append("}\n");
  return s;
}

std::string header(const std::vector<std::string>& cols) {
  std::string s;
  for (size_t i = 0; i < cols.size(); ++i) {
    if (i) s.append(",");
    s.append(cols[i]);
  }
  s.append("\n");
  return s;
}

}  // namespace

void parse_metrics_csv(const std::string& text, const std::string& name,
                       std::vector<std::string>& columns, std::vector<std::vector<double>>& rows) {
  columns.clear();
  rows.clear();
  size_t pos = 0;
  int line_no = 0;
  while (pos < text.size()) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    const std::string line = text.substr(pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    if (line.empty()) continue;
    std::vector<std::string> cells;
    size_t a = 0;
    while (true) {
      const size_t c = line.find(',', a);
      cells.push_back(line.substr(a, c == std::string::npos ? std::string::npos : c - a));
      if (c == std::string::npos) break;
      a = c + 1;
    }
    if (columns.empty()) {
      columns = cells;
      continue;
    }
    if (cells.size() != columns.size())
      throw Error(name + ":" + std::to_string(line_no) + ": expected " +
                  std::to_string(columns.size()) + " cells, got " + std::to_string(cells.size()));
    std::vector<double> row;
    for (auto& c : cells) {
      if (c.empty()) {
        row.push_back(NAN);
        continue;
      }
      try {
        size_t used = 0;
        row.push_back(std::stod(c, &used));
        if (used != c.size()) throw std::invalid_argument(c);
      } catch (const std::exception&) {
        throw Error(name + ":" + std::to_string(line_no) + ": expected a number, got '" + c + "'");
      }
    }
    rows.push_back(std::move(row));
  }
}

MetricsLog::MetricsLog(std::string dir, std::vector<std::string> columns)
    : dir_(std::move(dir)), columns_(std::move(columns)) {
  write_file_atomic(dir_ + "/metrics.csv", header(columns_));
  write_file_atomic(dir_ + "/metrics.jsonl", "");
  open_append();
}

MetricsLog MetricsLog::resume(std::string dir, std::vector<std::string> columns, int64_t update) {
  MetricsLog m;
  m.dir_ = std::move(dir);
  m.columns_ = std::move(columns);
  const std::string path = m.dir_ + "/metrics.csv";
  const std::string text = read_file(path);
  std::vector<std::string> cols;
  std::vector<std::vector<double>> rows;
  parse_metrics_csv(text, path, cols, rows);
  if (cols != m.columns_) {
    // a log written before columns were added: its columns must be this run's with some left
    // out, in the same order, and its rows get the others empty (NaN)
    std::vector<size_t> from;  // per column of this run, its index in the log, or npos
    size_t j = 0;
    for (const auto& c : m.columns_) {
      const bool match = j < cols.size() && cols[j] == c;
      from.push_back(match ? j++ : std::string::npos);
    }
    if (j != cols.size())
      throw Error(path + ": its columns (" + header(cols).substr(0, header(cols).size() - 1) +
                  ") are not this run's (" +
                  header(m.columns_).substr(0, header(m.columns_).size() - 1) + ")");
    for (auto& r : rows) {
      std::vector<double> wide(from.size(), std::numeric_limits<double>::quiet_NaN());
      for (size_t i = 0; i < from.size(); ++i)
        if (from[i] != std::string::npos) wide[i] = r[from[i]];
      r = std::move(wide);
    }
    cols = m.columns_;
  }
  std::vector<std::vector<double>> later;
  for (auto& r : rows) (r[0] <= update ? m.rows_ : later).push_back(r);
  if (!later.empty()) {
    std::string aside = header(cols);
    for (auto& r : later) aside += csv_line(r);
    write_file_atomic(m.dir_ + "/metrics.after_update_" + std::to_string(update) + ".csv", aside);
  }
  std::string csv = header(m.columns_), jsonl;
  for (auto& r : m.rows_) {
    csv += csv_line(r);
    jsonl += json_line(m.columns_, r);
  }
  write_file_atomic(path, csv);
  write_file_atomic(m.dir_ + "/metrics.jsonl", jsonl);
  m.open_append();
  return m;
}

MetricsLog::MetricsLog(MetricsLog&& o) noexcept
    : dir_(std::move(o.dir_)),
      columns_(std::move(o.columns_)),
      rows_(std::move(o.rows_)),
      csv_(o.csv_),
      jsonl_(o.jsonl_) {
  o.csv_ = o.jsonl_ = nullptr;
}

MetricsLog::~MetricsLog() {
  if (csv_) std::fclose(csv_);
  if (jsonl_) std::fclose(jsonl_);
}

void MetricsLog::open_append() {
  csv_ = std::fopen((dir_ + "/metrics.csv").c_str(), "a");
  jsonl_ = std::fopen((dir_ + "/metrics.jsonl").c_str(), "a");
  if (!csv_ || !jsonl_) throw IoError("cannot append to the metrics files in " + dir_);
}

void MetricsLog::append(const std::vector<double>& row) {
  if (row.size() != columns_.size())
    throw std::invalid_argument("MetricsLog::append: row of " + std::to_string(row.size()) +
                                " values for " + std::to_string(columns_.size()) + " columns");
  rows_.push_back(row);
  const std::string c = csv_line(row), j = json_line(columns_, row);
  std::fputs(c.c_str(), csv_);
  std::fputs(j.c_str(), jsonl_);
  std::fflush(csv_);
  std::fflush(jsonl_);
}

std::vector<double> MetricsLog::column(const std::string& name) const {
  for (size_t i = 0; i < columns_.size(); ++i)
    if (columns_[i] == name) {
      std::vector<double> out;
      for (auto& r : rows_) out.push_back(r[i]);
      return out;
    }
  throw std::out_of_range("no metrics column " + name);
}

void MetricsLog::plot(const std::string& title) const {
  const auto steps = column("steps");
  auto panel = [&](const std::string& t, const std::string& ylabel, const std::string& col) {
    plot::Panel p;
    p.title = t;
    p.xlabel = "slot-steps";
    p.ylabel = ylabel;
    plot::Series s;
    s.x = steps;
    s.y = column(col);
    p.series.push_back(std::move(s));
    return p;
  };
  const plot::Panel ret = panel(title, "mean episode return", "return");
  const plot::Panel succ = panel("success rate", "fraction of episodes", "success");
  const plot::Panel len = panel("episode length", "control steps", "length");
  std::vector<plot::Panel> panels = {ret, succ, len};
  // a suite run: one line per task (columns return_<label>)
  plot::Panel per;
  per.title = "mean episode return per task";
  per.xlabel = "slot-steps";
  per.ylabel = "return";
  for (const std::string& c : columns_) {
    if (c.rfind("return_", 0) != 0) continue;
    plot::Series s;
    s.name = c.substr(7);
    s.x = steps;
    s.y = column(c);
    per.series.push_back(std::move(s));
  }
  if (!per.series.empty()) panels.insert(panels.begin() + 1, std::move(per));
  write_file_atomic(dir_ + "/learning_curve.svg", plot::svg(panels, 760, 260));
}

}  // namespace bidex::rl
