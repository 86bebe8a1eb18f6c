#include "rl/config_fields.h"

#include <cmath>
#include <cstdio>

namespace bidex::rl {

int read_int(const YamlView& parent, const char* key, int lo) {
  auto n = parent.child(key);
  const int x = n.as<int>();
  if (x < lo) n.fail("an integer >= " + std::to_string(lo), n.repr());
  return x;
}

double read_real(const YamlView& parent, const char* key, double lo, double hi, bool open_lo) {
  auto n = parent.child(key);
  const double x = n.as<double>();
  if (!std::isfinite(x) || (open_lo ? x <= lo : x < lo) || x > hi) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "a number in %s%g, %g]", open_lo ? "(" : "[", lo, hi);
    n.fail(buf, n.repr());
  }
  return x;
}

std::vector<int> read_widths(const YamlView& list) {
  std::vector<int> out;
  for (auto& item : list.items()) {
    const int x = item.as<int>();
    if (x < 1) item.fail("a layer width >= 1", item.repr());
    out.push_back(x);
  }
  if (out.empty()) list.fail("at least one hidden layer", "[]");
  return out;
}

std::string read_choice(const YamlView& parent, const char* key,
                        const std::vector<std::string>& allowed) {
  auto n = parent.child(key);
  const std::string x = n.as<std::string>();
  std::string all;
  for (auto& a : allowed) {
    if (a == x) return x;
    all += (all.empty() ? "" : ", ") + a;
  }
  n.fail("one of " + all, n.repr());
}

}  // namespace bidex::rl
