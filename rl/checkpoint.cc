#include "rl/checkpoint.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include <dirent.h>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/files.h"

namespace bidex::rl {

namespace {

constexpr const char* kMagic = "bidex-checkpoint 1";

uint64_t fnv1a(const char* p, size_t n) {
  uint64_t h = 1469598103934665603ull;
  for (size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(p[i]);
    h *= 1099511628211ull;
  }
  return h;
}

std::string hex(uint64_t h) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

struct Parsed {
  CheckpointMeta meta;
  size_t payload_offset = 0, payload_size = 0;
  std::string payload_hash;
};

[[noreturn]] void bad(const std::string& path, const std::string& why) {
  throw Error("checkpoint " + path + ": " + why);
}

Parsed parse(const std::string& path, const std::string& bytes) {
  const size_t l1 = bytes.find('\n');
  if (l1 == std::string::npos || bytes.compare(0, l1, kMagic) != 0)
    bad(path, std::string("not a bidex checkpoint (expected a first line '") + kMagic + "')");
  const size_t l2 = bytes.find('\n', l1 + 1);
  if (l2 == std::string::npos) bad(path, "truncated inside its header");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(bytes.substr(l1 + 1, l2 - l1 - 1));
  } catch (const std::exception& e) {
    bad(path, std::string("corrupted header (") + e.what() + ")");
  }
  Parsed p;
  try {
    p.meta.task = j.at("task").get<std::string>();
    p.meta.task_version = j.at("task_version").get<std::string>();
    p.meta.algo = j.at("algo").get<std::string>();
    p.meta.obs_dim = j.at("obs_dim").get<int64_t>();
    p.meta.act_dim = j.at("act_dim").get<int64_t>();
    p.meta.update = j.at("update").get<int64_t>();
    p.meta.steps = j.at("steps").get<int64_t>();
    p.meta.config_hash = j.at("config_hash").get<std::string>();
    p.payload_size = j.at("payload_bytes").get<size_t>();
    p.payload_hash = j.at("payload_fnv1a64").get<std::string>();
  } catch (const std::exception& e) {
    bad(path, std::string("header lacks a field (") + e.what() + ")");
  }
  p.payload_offset = l2 + 1;
  const size_t have = bytes.size() - p.payload_offset;
  if (have != p.payload_size)
    bad(path, "truncated or padded: the header announces " + std::to_string(p.payload_size) +
                  " bytes of weights, the file holds " + std::to_string(have));
  return p;
}

}  // namespace

void save_checkpoint(const std::string& path, const CheckpointMeta& m,
                     torch::serialize::OutputArchive& archive) {
  std::ostringstream payload;
  archive.save_to(payload);
  const std::string bytes = payload.str();
  nlohmann::json j = {{"task", m.task},
                      {"task_version", m.task_version},
                      {"algo", m.algo},
                      {"obs_dim", m.obs_dim},
                      {"act_dim", m.act_dim},
                      {"update", m.update},
                      {"steps", m.steps},
                      {"config_hash", m.config_hash},
                      {"payload_bytes", bytes.size()},
                      {"payload_fnv1a64", hex(fnv1a(bytes.data(), bytes.size()))}};
  std::string out = std::string(kMagic) + "\n" + j.dump() + "\n";
  out += bytes;
  write_file_atomic(path, out);
}

CheckpointMeta read_checkpoint_meta(const std::string& path) {
  return parse(path, read_file(path)).meta;
}

CheckpointMeta load_checkpoint(const std::string& path, torch::serialize::InputArchive& archive,
                               const torch::Device& device) {
  const std::string bytes = read_file(path);
  Parsed p = parse(path, bytes);
  if (hex(fnv1a(bytes.data() + p.payload_offset, p.payload_size)) != p.payload_hash)
    bad(path, "corrupted: the weights' hash does not match the header's");
  try {
    archive.load_from(bytes.data() + p.payload_offset, p.payload_size, device);
  } catch (const std::exception& e) {
    std::string msg = e.what();
    bad(path, "LibTorch could not read the weights (" + msg.substr(0, msg.find('\n')) + ")");
  }
  return p.meta;
}

std::vector<std::string> list_checkpoints(const std::string& run_dir) {
  std::vector<std::string> names;
  const std::string dir = run_dir + "/checkpoints";
  if (DIR* d = ::opendir(dir.c_str())) {
    while (dirent* e = ::readdir(d)) {
      std::string n = e->d_name;
      if (n.size() > 5 && n.rfind("update_", 0) == 0 && n.compare(n.size() - 5, 5, ".ckpt") == 0)
        names.push_back(n);
    }
    ::closedir(d);
  }
  std::sort(names.begin(), names.end());
  for (auto& n : names) n = dir + "/" + n;
  return names;
}

void load_module_checked(torch::nn::Module& m, torch::serialize::InputArchive& archive,
                         const std::string& path, const std::string& what) {
  std::vector<std::pair<std::string, std::vector<int64_t>>> want;
  for (auto& p : m.named_parameters()) want.emplace_back(p.key(), p.value().sizes().vec());
  for (auto& b : m.named_buffers()) want.emplace_back(b.key(), b.value().sizes().vec());
  try {
    m.load(archive);
  } catch (const c10::Error& e) {
    std::string msg = e.what();
    throw Error("checkpoint " + path + ": does not fit " + what + " (" +
                msg.substr(0, msg.find('\n')) + ")");
  }
  auto params = m.named_parameters();
  auto buffers = m.named_buffers();
  for (auto& [name, sizes] : want) {
    const torch::Tensor* t = params.find(name);
    if (!t) t = buffers.find(name);
    if (!t || t->sizes().vec() != sizes)
      throw Error("checkpoint " + path + ": does not fit " + what + ": " + name + " has shape " +
                  (t ? c10::str(t->sizes()) : std::string("(missing)")) + ", expected " +
                  c10::str(c10::IntArrayRef(sizes)));
  }
}

void read_checked(const std::string& path, const std::string& problem,
                  const std::function<void()>& read) {
  try {
    read();
  } catch (const c10::Error& e) {
    const std::string msg = e.what();
    throw Error("checkpoint " + path + ": " + problem + " (" + msg.substr(0, msg.find('\n')) + ")");
  }
}

void read_module(torch::serialize::InputArchive& root, const std::string& name,
                 torch::nn::Module& m, const std::string& path, const std::string& what) {
  torch::serialize::InputArchive a;
  root.read(name, a);
  load_module_checked(m, a, path, what);
}

}  // namespace bidex::rl
