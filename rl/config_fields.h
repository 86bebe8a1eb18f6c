// Strict readers of the training YAML's sections, shared by rl's own sections (config.cc) and by
// the sections of algorithm families registered from outside rl (metarl): every failure is a
// ConfigError naming the file, the key, what was expected and what was found.
#pragma once

#include <string>
#include <vector>

#include "core/yaml.h"

namespace bidex::rl {

// parent[key], an integer >= lo.
int read_int(const YamlView& parent, const char* key, int lo);
// parent[key], a finite number in [lo, hi] ((lo, hi] when open_lo).
double read_real(const YamlView& parent, const char* key, double lo, double hi, bool open_lo);
// A list of hidden layer widths, each >= 1, at least one.
std::vector<int> read_widths(const YamlView& list);
// parent[key], one of `allowed`.
std::string read_choice(const YamlView& parent, const char* key,
                        const std::vector<std::string>& allowed);

}  // namespace bidex::rl
