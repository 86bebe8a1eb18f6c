#include "core/yaml.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "core/files.h"

namespace bidex {

namespace {

std::string with_line(const std::string& file, const YAML::Node& node) {
  if (!node.IsDefined() || node.Mark().line < 0) return file;
  return file + ":" + std::to_string(node.Mark().line + 1);
}

template <size_t N>
std::array<double, N> fixed_list(const YamlView& v) {
  std::array<double, N> out{};
  std::string expected = "a list of " + std::to_string(N) + " numbers";
  if (!v.node().IsSequence() || v.node().size() != N) v.fail(expected, v.repr());
  auto items = v.items();
  for (size_t i = 0; i < N; ++i) out[i] = items[i].as<double>();
  return out;
}

}  // namespace

YamlView YamlView::load_file(const std::string& path) {
  std::string text = read_file(path);
  return load_string(text, path);
}

YamlView YamlView::load_string(const std::string& text, const std::string& name) {
  try {
    YAML::Node root = YAML::Load(text);
    return YamlView(root, name, "");
  } catch (const YAML::Exception& e) {
    throw ConfigError(name + ":" + std::to_string(e.mark.line + 1), "", "valid YAML",
                      "a syntax error (" + e.msg + ")");
  }
}

std::string YamlView::repr() const {
  if (!node_.IsDefined() || node_.IsNull()) return "nothing";
  YAML::Emitter out;
  out << YAML::Flow << node_;
  std::string s = out.c_str();
  if (s.size() > 80) s = s.substr(0, 77) + "...";
  return "'" + s + "'";
}

void YamlView::fail(const std::string& expected, const std::string& actual) const {
  throw ConfigError(with_line(file_, node_), path_.empty() ? "(top level)" : path_, expected,
                    actual);
}

void YamlView::expect_map() const {
  if (!node_.IsMap()) fail("a mapping of keys to values", repr());
}

void YamlView::expect_seq() const {
  if (!node_.IsSequence()) fail("a list", repr());
}

YamlView YamlView::child(const std::string& key) const {
  expect_map();
  YAML::Node c = node_[key];
  std::string p = path_.empty() ? key : path_ + "." + key;
  if (!c) throw ConfigError(with_line(file_, node_), p, "a value for the required key", "none");
  return YamlView(c, file_, p);
}

std::optional<YamlView> YamlView::maybe(const std::string& key) const {
  expect_map();
  YAML::Node c = node_[key];
  if (!c) return std::nullopt;
  return YamlView(c, file_, path_.empty() ? key : path_ + "." + key);
}

std::vector<YamlView> YamlView::items() const {
  expect_seq();
  std::vector<YamlView> out;
  for (size_t i = 0; i < node_.size(); ++i)
    out.emplace_back(node_[i], file_, path_ + "[" + std::to_string(i) + "]");
  return out;
}

std::vector<std::string> YamlView::keys() const {
  expect_map();
  std::vector<std::string> out;
  for (auto it = node_.begin(); it != node_.end(); ++it) out.push_back(it->first.as<std::string>());
  return out;
}

void YamlView::allow_keys(std::initializer_list<std::string_view> allowed) const {
  expect_map();
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    std::string k = it->first.as<std::string>();
    bool ok = false;
    for (auto a : allowed) ok = ok || a == k;
    if (ok) continue;
    std::string list;
    for (auto a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
    std::string p = path_.empty() ? k : path_ + "." + k;
    throw ConfigError(with_line(file_, it->first), p, "one of the keys {" + list + "}",
                      "unknown key '" + k + "'");
  }
}

template <>
double YamlView::as<double>() const {
  if (!node_.IsScalar()) fail("a number", repr());
  double v = 0;
  try {
    v = node_.as<double>();
  } catch (const YAML::Exception&) {
    fail("a number", repr());
  }
  if (!std::isfinite(v)) fail("a finite number", repr());
  return v;
}

template <>
int YamlView::as<int>() const {
  if (!node_.IsScalar()) fail("an integer", repr());
  try {
    return node_.as<int>();
  } catch (const YAML::Exception&) {
    fail("an integer", repr());
  }
}

template <>
bool YamlView::as<bool>() const {
  if (!node_.IsScalar()) fail("true or false", repr());
  try {
    return node_.as<bool>();
  } catch (const YAML::Exception&) {
    fail("true or false", repr());
  }
}

template <>
std::string YamlView::as<std::string>() const {
  if (!node_.IsScalar()) fail("a string", repr());
  return node_.as<std::string>();
}

template <>
std::vector<double> YamlView::as<std::vector<double>>() const {
  if (!node_.IsSequence()) fail("a list of numbers", repr());
  std::vector<double> out;
  for (auto& it : items()) out.push_back(it.as<double>());
  return out;
}

template <>
std::vector<std::string> YamlView::as<std::vector<std::string>>() const {
  if (!node_.IsSequence()) fail("a list of strings", repr());
  std::vector<std::string> out;
  for (auto& it : items()) out.push_back(it.as<std::string>());
  return out;
}

template <>
std::array<double, 2> YamlView::as<std::array<double, 2>>() const { return fixed_list<2>(*this); }
template <>
std::array<double, 3> YamlView::as<std::array<double, 3>>() const { return fixed_list<3>(*this); }
template <>
std::array<double, 4> YamlView::as<std::array<double, 4>>() const { return fixed_list<4>(*this); }

}  // namespace bidex
