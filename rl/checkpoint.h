// Checkpoint files: a text header (a magic line, then one JSON line: task, dimensions, update,
// steps, config hash, payload size and hash), then LibTorch's serialised archive (networks,
// normalisers, optimiser, learning rate). Written atomically; a truncated or corrupted file, or a
// checkpoint of another task or shape, is a clear error before LibTorch parses anything.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <torch/torch.h>

namespace bidex::rl {

struct CheckpointMeta {
  std::string task;          // task id
  std::string task_version;  // versioned id, e.g. catch_underarm-v1
  std::string algo;
  int64_t obs_dim = 0, act_dim = 0;
  int64_t update = 0;        // updates done
  int64_t steps = 0;         // slot-steps done
  std::string config_hash;
};

// Writes `meta` and the archive to `path` atomically.
void save_checkpoint(const std::string& path, const CheckpointMeta& meta,
                     torch::serialize::OutputArchive& archive);

// Reads the header only (IoError or bidex::Error naming the file when it is not a checkpoint,
// is truncated or corrupted).
CheckpointMeta read_checkpoint_meta(const std::string& path);

// Reads and verifies the whole file, then loads the archive onto `device`.
CheckpointMeta load_checkpoint(const std::string& path, torch::serialize::InputArchive& archive,
                               const torch::Device& device);

// Checkpoint files of a run folder (<run>/checkpoints/update_XXXXXXXX.ckpt), oldest first.
std::vector<std::string> list_checkpoints(const std::string& run_dir);

// Loads a module's parameters and buffers from `archive` and checks that every tensor kept its
// shape (LibTorch's Module::load silently takes the archive's shapes); a mismatch is an Error
// naming `path`, the tensor, both shapes and `what` (e.g. "this run's networks").
void load_module_checked(torch::nn::Module& m, torch::serialize::InputArchive& archive,
                         const std::string& path, const std::string& what);

// One named part of an algorithm's state (a module or an optimiser), in its own archive.
template <class Part>
void write_part(torch::serialize::OutputArchive& root, const std::string& name, const Part& part) {
  torch::serialize::OutputArchive a;
  part.save(a);
  root.write(name, a);
}
// Reads the module part `name` into `m`, checked as load_module_checked does.
void read_module(torch::serialize::InputArchive& root, const std::string& name,
                 torch::nn::Module& m, const std::string& path, const std::string& what);
// Reads the optimiser part `name` into `o` (a LibTorch optimiser, or FlatAdam: anything with
// load(InputArchive&)).
template <class Optimizer>
void read_optimizer(torch::serialize::InputArchive& root, const std::string& name, Optimizer& o) {
  torch::serialize::InputArchive a;
  root.read(name, a);
  o.load(a);
}

// A list of optimisers (one per agent, say) as the parts PREFIX_0, PREFIX_1, ...
template <class Optimizer>
void write_optimizers(torch::serialize::OutputArchive& root, const std::string& prefix,
                      const std::vector<std::unique_ptr<Optimizer>>& opts) {
  for (size_t k = 0; k < opts.size(); ++k) write_part(root, prefix + std::to_string(k), *opts[k]);
}
template <class Optimizer>
void read_optimizers(torch::serialize::InputArchive& root, const std::string& prefix,
                     const std::vector<std::unique_ptr<Optimizer>>& opts) {
  for (size_t k = 0; k < opts.size(); ++k)
    read_optimizer(root, prefix + std::to_string(k), *opts[k]);
}

// Runs `read` (an algorithm reading its state from a loaded archive) and turns LibTorch's errors
// into an Error naming `path`: "checkpoint PATH: <problem> (<LibTorch's first line>)".
void read_checked(const std::string& path, const std::string& problem,
                  const std::function<void()>& read);

}  // namespace bidex::rl
