// Strict YAML reading: every value is read through a YamlView that knows the file and the key
// path, so every error names the file, the key, what was expected and what was found. Unknown
// keys are errors (allow_keys).
//
// A file may build on another: a top-level `extends: PATH` (relative to the file's folder) reads
// PATH first and merges this file's other keys over it. The overlay is strict: every key it sets
// must exist in the parent (a misspelt key is an error, never a silent addition); maps merge key
// by key, recursively; a list or a scalar replaces the parent's value whole. Parents may extend
// further files; a cycle is an error. Views of such a file name it "child.yaml (extends
// parent.yaml)" and give no line numbers (a merged value may come from either file).
#pragma once

#include <array>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "core/error.h"

namespace bidex {

class YamlView {
 public:
  // Parses a file (following `extends`, see above); a missing file is an IoError, a syntax
  // error a ConfigError with its line.
  static YamlView load_file(const std::string& path);
  // Parses text; `name` stands in for the file name in messages.
  static YamlView load_string(const std::string& text, const std::string& name);

  // `lines`: whether messages add the node's line to the file name (false for merged files).
  YamlView(YAML::Node node, std::string file, std::string path, bool lines = true)
      : node_(std::move(node)), file_(std::move(file)), path_(std::move(path)), lines_(lines) {}

  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }
  const YAML::Node& node() const { return node_; }
  bool is_map() const { return node_.IsMap(); }
  bool is_seq() const { return node_.IsSequence(); }
  bool has(const std::string& key) const { return node_.IsMap() && node_[key]; }

  // A required child of a map; missing -> ConfigError naming the key.
  YamlView child(const std::string& key) const;
  // An optional child of a map.
  std::optional<YamlView> maybe(const std::string& key) const;
  // Elements of a sequence (requires a sequence).
  std::vector<YamlView> items() const;
  // Keys of a map, in file order (requires a map).
  std::vector<std::string> keys() const;

  // Requires a map whose keys are all in `allowed`; otherwise names the first unknown key.
  void allow_keys(std::initializer_list<std::string_view> allowed) const;
  void allow_keys(const std::vector<std::string>& allowed) const;
  void expect_map() const;
  void expect_seq() const;

  // Scalar conversions; a wrong type is a ConfigError with the expected type.
  template <class T>
  T as() const;
  template <class T>
  T req(const std::string& key) const { return child(key).as<T>(); }
  template <class T>
  T opt(const std::string& key, T fallback) const {
    auto c = maybe(key);
    return c ? c->as<T>() : fallback;
  }

  // Throws a ConfigError at this node's key path.
  [[noreturn]] void fail(const std::string& expected, const std::string& actual) const;
  // The node's text as written, for messages.
  std::string repr() const;

 private:
  std::string where(const YAML::Node& node) const;  // file_, with the node's line if known

  YAML::Node node_;
  std::string file_;
  std::string path_;
  bool lines_ = true;
};

// `path` as seen from the folder of `file` (unchanged when absolute or when `file` has no
// folder part): how `extends` and other file references inside a YAML file are resolved.
std::string path_beside(const std::string& file, const std::string& path);

// supported conversions
template <> double YamlView::as<double>() const;
template <> int YamlView::as<int>() const;
template <> bool YamlView::as<bool>() const;
template <> std::string YamlView::as<std::string>() const;
template <> std::vector<double> YamlView::as<std::vector<double>>() const;
template <> std::vector<std::string> YamlView::as<std::vector<std::string>>() const;
template <> std::array<double, 2> YamlView::as<std::array<double, 2>>() const;
template <> std::array<double, 3> YamlView::as<std::array<double, 3>>() const;
template <> std::array<double, 4> YamlView::as<std::array<double, 4>>() const;

}  // namespace bidex
