// Shared helpers of the test suite: the real hand spec and physics files loaded once, models
// built once per process, temp folders, error-message checks and stdout/stderr capture.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include <catch2/catch.hpp>

#include "core/error.h"
#include "core/files.h"
#include "sim/hand_spec.h"
#include "sim/physics.h"
#include "sim/scene.h"

namespace bidex::test {

namespace fs = std::filesystem;

// The project's own configs/hands/shadow.yaml and configs/sim/physics.yaml, read once.
inline const sim::HandSpec& shadow() {
  static const sim::HandSpec spec = sim::load_hand_spec(sim::default_hand_path());
  return spec;
}
inline const sim::PhysicsOptions& physics() {
  static const sim::PhysicsOptions p = sim::load_physics(sim::default_physics_path());
  return p;
}

// The reference scene (two free hands and an egg) at the project's physics, built once.
inline const sim::SimModel& two_hand_model() {
  static const sim::SimModel m = sim::two_hand_scene(shadow(), physics()).build("two_hand_scene");
  return m;
}

// Both hands on fixed bases, facing each other as in `bidex model`, built once.
inline const sim::SimModel& fixed_hands_model() {
  static const sim::SimModel m = [] {
    sim::SceneBuilder sb(physics());
    sb.add_hand(shadow(), {sim::Side::kRight, sim::Pose::rpy({0, 0, 0.5}, 0, 0, 0),
                           sim::Base::kFixed});
    sb.add_hand(shadow(), {sim::Side::kLeft, sim::Pose::rpy({0, -1, 0.5}, 0, 0, M_PI),
                           sim::Base::kFixed});
    return sb.build("fixed_hands");
  }();
  return m;
}

// A fresh, empty folder under the system temp folder, removed with everything in it at scope end.
class TempDir {
 public:
  TempDir() {
    static std::random_device rd;
    for (int attempt = 0; attempt < 100; ++attempt) {
      fs::path p = fs::temp_directory_path() /
                   ("bidex_test_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
      std::error_code ec;
      if (fs::create_directory(p, ec)) {
        path_ = p;
        return;
      }
    }
    throw std::runtime_error("cannot create a temp folder");
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  // names of the entries of the folder, sorted
  std::vector<std::string> list() const {
    std::vector<std::string> out;
    for (auto& e : fs::directory_iterator(path_)) out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  fs::path path_;
};

// configs/sim/physics.yaml with the GPU backend stepping the CPU's timestep and substeps (its
// `gpu` block's own step removed), for tests that compare the two paths step by step; written
// once per test process.
inline const std::string& same_step_physics_file() {
  static TempDir dir;
  static const std::string path = [] {
    std::ifstream in(sim::default_physics_path());
    std::string line, text;
    bool in_gpu = false;
    while (std::getline(in, line)) {
      if (!line.empty() && line[0] != ' ' && line[0] != '#') in_gpu = line.rfind("gpu:", 0) == 0;
      if (in_gpu && (line.rfind("  timestep:", 0) == 0 || line.rfind("  substeps:", 0) == 0))
        continue;
      text += line + "\n";
    }
    const std::string out = dir.file("physics-same-step.yaml");
    std::ofstream(out) << text;
    return out;
  }();
  return path;
}

// Replaces exactly one occurrence of `from` in `text` (fails the test if it is absent or repeated).
inline std::string replace_once(std::string text, const std::string& from, const std::string& to) {
  size_t at = text.find(from);
  INFO("editing the YAML text: looking for '" << from << "'");
  REQUIRE(at != std::string::npos);
  REQUIRE(text.find(from, at + 1) == std::string::npos);
  return text.replace(at, from.size(), to);
}

// 1-based line of the first line of `text` containing `needle`.
inline int line_of(const std::string& text, const std::string& needle) {
  size_t at = text.find(needle);
  REQUIRE(at != std::string::npos);
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
}

// Runs `f`, which must throw a ConfigError; returns it.
inline ConfigError config_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e;
  }
  FAIL("expected a ConfigError, none was thrown");
  throw std::logic_error("unreachable");
}

// Checks that a ConfigError names the file, the key path, and the expected and actual parts,
// both in its fields and in what().
inline void check_config_error(const ConfigError& e, const std::string& file,
                               const std::string& key, const std::string& expected,
                               const std::string& actual) {
  std::string what = e.what();
  INFO("what(): " << what);
  CHECK(what.find(file) != std::string::npos);
  CHECK(e.file().rfind(file, 0) == 0);  // the file, maybe followed by ":<line>"
  CHECK(e.key() == key);
  CHECK(what.find(key) != std::string::npos);
  CHECK(e.expected().find(expected) != std::string::npos);
  CHECK(what.find("expected " + e.expected()) != std::string::npos);
  CHECK(e.actual().find(actual) != std::string::npos);
  CHECK(what.find("got " + e.actual()) != std::string::npos);
}

// Captures everything written to the process's stdout and stderr (file descriptors 1 and 2, so
// C printf and MuJoCo's own printing are caught) while alive.
class CaptureOutput {
 public:
  CaptureOutput() : file_(std::tmpfile()) {
    REQUIRE(file_ != nullptr);
    std::fflush(stdout);
    std::fflush(stderr);
    saved_out_ = ::dup(1);
    saved_err_ = ::dup(2);
    ::dup2(::fileno(file_), 1);
    ::dup2(::fileno(file_), 2);
  }
  ~CaptureOutput() {
    restore();
    if (file_) std::fclose(file_);
  }
  // Stops capturing and returns what was written.
  std::string text() {
    restore();
    std::string out;
    std::rewind(file_);
    char buf[4096];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, file_)) > 0) out.append(buf, n);
    return out;
  }

 private:
  void restore() {
    if (saved_out_ < 0) return;
    std::fflush(stdout);
    std::fflush(stderr);
    ::dup2(saved_out_, 1);
    ::dup2(saved_err_, 2);
    ::close(saved_out_);
    ::close(saved_err_);
    saved_out_ = saved_err_ = -1;
  }
  std::FILE* file_ = nullptr;
  int saved_out_ = -1, saved_err_ = -1;
};

// Bitwise equality of two double arrays (NaN payloads included).
inline bool same_bits(const double* a, const double* b, size_t n) {
  return std::memcmp(a, b, n * sizeof(double)) == 0;
}

constexpr double kDeg = M_PI / 180.0;

}  // namespace bidex::test
