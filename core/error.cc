#include "core/error.h"

namespace bidex {

namespace {
std::string compose(const std::string& file, const std::string& key, const std::string& expected,
                    const std::string& actual) {
  std::string msg = file.empty() ? std::string("<input>") : file;
  if (!key.empty()) msg += ": " + key;
  msg += ": expected " + expected + ", got " + actual;
  return msg;
}
}  // namespace

ConfigError::ConfigError(std::string file, std::string key, std::string expected,
                         std::string actual)
    : Error(compose(file, key, expected, actual)),
      file_(std::move(file)),
      key_(std::move(key)),
      expected_(std::move(expected)),
      actual_(std::move(actual)) {}

}  // namespace bidex
