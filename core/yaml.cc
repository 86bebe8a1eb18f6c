#include "core/yaml.h"

#include <climits>
#include <cmath>
#include <cstdlib>
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

std::string path_beside(const std::string& file, const std::string& path) {
  if (path.empty() || path[0] == '/') return path;
  const size_t slash = file.rfind('/');
  if (slash == std::string::npos) return path;
  std::string out = file.substr(0, slash + 1);
  out.append(path);
  return out;
}

namespace {

// The canonical path of an existing file (symlinks and ".." resolved), empty if there is none.
std::string canonical(const std::string& path) {
  char buf[PATH_MAX];
  if (!::realpath(path.c_str(), buf)) return "";
  return buf;
}

std::string key_list(const YAML::Node& map) {
  std::string out;
  for (auto it = map.begin(); it != map.end(); ++it) {
    if (!out.empty()) out.append(", ");
    out.append(it->first.as<std::string>());
  }
  return out;
}

// Merges `child` (a map of `child_file`) over `parent` in place: every key of the child must
// exist in the parent; maps merge recursively, anything else replaces the parent's value.
void overlay(YAML::Node parent, const YAML::Node& child, const std::string& child_file,
             const std::string& parent_name, const std::string& path) {
  for (auto it = child.begin(); it != child.end(); ++it) {
    const std::string key = it->first.as<std::string>();
    if (path.empty() && key == "extends") continue;
    const std::string p = path.empty() ? key : path + "." + key;
    const YAML::Node& cparent = parent;
    YAML::Node old = cparent[key];
    if (!old)
      throw ConfigError(with_line(child_file, it->first), p,
                        std::string("a key of ").append(parent_name).append(" {")
                            .append(key_list(parent)).append("}"),
                        std::string("unknown key '").append(key).append("'"));
    if (old.IsMap() && it->second.IsMap())
      overlay(old, it->second, child_file, parent_name, p);
    else
      parent[key] = it->second;
  }
}

struct Loaded {
  YAML::Node root;
  std::string name;     // the file name for messages
  bool merged = false;  // built from several files
};

// Loads `path`, following `extends`; `chain` holds the canonical paths of the files that
// extend this one (for the cycle check).
Loaded load_chain(const std::string& path, std::vector<std::string>& chain) {
  Loaded out{YamlView::load_string(read_file(path), path).node(), path, false};
  const YAML::Node& root = out.root;
  if (!root.IsMap() || !root["extends"]) return out;
  const YamlView ext(root["extends"], path, "extends");
  const std::string rel = ext.as<std::string>();
  const std::string parent = canonical(path_beside(path, rel));
  if (parent.empty())
    ext.fail("the path of a readable YAML file (relative to this file's folder)",
             std::string("'").append(rel).append("', which does not exist"));
  for (const auto& c : chain) {
    if (c != parent) continue;
    std::string cycle;
    for (const auto& f : chain) cycle.append(f).append(" -> ");
    cycle.append(parent);
    ext.fail("a chain of files without a cycle", "the cycle " + cycle);
  }
  chain.push_back(parent);
  Loaded base = load_chain(parent, chain);
  chain.pop_back();
  YamlView(base.root, base.name, "", !base.merged).expect_map();
  overlay(base.root, out.root, path, base.name, "");
  std::string name = path;
  name.append(" (extends ").append(base.name).append(")");
  return {base.root, name, true};
}

}  // namespace

YamlView YamlView::load_file(const std::string& path) {
  std::vector<std::string> chain;
  const std::string self = canonical(path);
  if (!self.empty()) chain.push_back(self);
  Loaded l = load_chain(path, chain);
  return YamlView(l.root, l.name, "", !l.merged);
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

std::string YamlView::where(const YAML::Node& node) const {
  return lines_ ? with_line(file_, node) : file_;
}

void YamlView::fail(const std::string& expected, const std::string& actual) const {
  throw ConfigError(where(node_), path_.empty() ? "(top level)" : path_, expected,
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
  if (!c) throw ConfigError(where(node_), p, "a value for the required key", "none");
  return YamlView(c, file_, p, lines_);
}

std::optional<YamlView> YamlView::maybe(const std::string& key) const {
  expect_map();
  YAML::Node c = node_[key];
  if (!c) return std::nullopt;
  return YamlView(c, file_, path_.empty() ? key : path_ + "." + key, lines_);
}

std::vector<YamlView> YamlView::items() const {
  expect_seq();
  std::vector<YamlView> out;
  for (size_t i = 0; i < node_.size(); ++i)
    out.emplace_back(node_[i], file_, path_ + "[" + std::to_string(i) + "]", lines_);
  return out;
}

std::vector<std::string> YamlView::keys() const {
  expect_map();
  std::vector<std::string> out;
  for (auto it = node_.begin(); it != node_.end(); ++it) out.push_back(it->first.as<std::string>());
  return out;
}

void YamlView::allow_keys(std::initializer_list<std::string_view> allowed) const {
  allow_keys(std::vector<std::string>(allowed.begin(), allowed.end()));
}

void YamlView::allow_keys(const std::vector<std::string>& allowed) const {
  expect_map();
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    std::string k = it->first.as<std::string>();
    bool ok = false;
    for (auto a : allowed) ok = ok || a == k;
    if (ok) continue;
    std::string list;
    for (auto& a : allowed) list.append(list.empty() ? "" : ", ").append(a);
    std::string p = path_.empty() ? k : path_ + "." + k;
    throw ConfigError(where(it->first), p, "one of the keys {" + list + "}",
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
