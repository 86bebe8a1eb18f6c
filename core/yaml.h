// Strict YAML reading: every value is read through a YamlView that knows the file and the key
// path, so every error names the file, the key, what was expected and what was found. Unknown
// keys are errors (allow_keys).
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
  // Parses a file; a missing file is an IoError, a syntax error a ConfigError with its line.
  static YamlView load_file(const std::string& path);
  // Parses text; `name` stands in for the file name in messages.
  static YamlView load_string(const std::string& text, const std::string& name);

  YamlView(YAML::Node node, std::string file, std::string path)
      : node_(std::move(node)), file_(std::move(file)), path_(std::move(path)) {}

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
  YAML::Node node_;
  std::string file_;
  std::string path_;
};

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
