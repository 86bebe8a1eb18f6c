// Typed errors raised at the edges of the system (config files, model files, command lines).
// Inside the per-step hot loop nothing throws: see sim::FaultFlags.
#pragma once

#include <stdexcept>
#include <string>

namespace bidex {

// Base of the errors a user can cause and fix (bad config, bad model, unreadable file): the
// command line reports them as one line and exits with status 2.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A configuration or input-file error. The message always names the file, the key path inside
// it, what was expected and what was found, e.g.
//   configs/hands/shadow.yaml: bodies[3].joint.range_deg: expected min < max, got [90, 10]
class ConfigError : public Error {
 public:
  ConfigError(std::string file, std::string key, std::string expected, std::string actual);

  const std::string& file() const { return file_; }
  const std::string& key() const { return key_; }
  const std::string& expected() const { return expected_; }
  const std::string& actual() const { return actual_; }

 private:
  std::string file_, key_, expected_, actual_;
};

// A model that MuJoCo refused to compile or load; carries MuJoCo's own message.
class ModelError : public Error {
 public:
  using Error::Error;
};

// An I/O failure (missing file, unwritable folder), naming the path and the reason.
class IoError : public Error {
 public:
  using Error::Error;
};

// A device or package the command needs is missing or failed (no GPU, no MuJoCo Warp, a CUDA
// driver call that failed): names what is missing and how to install it.
class DeviceError : public Error {
 public:
  using Error::Error;
};

}  // namespace bidex
