// Offline datasets on disk: one folder per dataset in Minari's layout,
//   DIR/data/main_data.hdf5   one group per episode, "episode_0", "episode_1", ...: the datasets
//                             observations (T+1 x obs_dim), actions (T x act_dim), rewards (T),
//                             terminations (T) and truncations (T); attributes id, total_steps
//   DIR/data/metadata.json    the dataset id, the env spec, the spaces, ref_min_score and
//                             ref_max_score, total steps and episodes, the code version and the
//                             SHA-256 of main_data.hdf5 (DatasetInfo below)
// written through libhdf5 with object time stamps off, so that the same episodes give the same
// bytes and the same checksum. Every failure names the file and the problem (DatasetError);
// a dataset is written into a temporary folder beside DIR and renamed into place when complete,
// so a killed writer leaves nothing half-written at DIR.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/error.h"

namespace bidex::offline {

// A dataset that cannot be read, is corrupted, or does not fit what it is used for; the message
// names the file and the problem.
class DatasetError : public Error {
 public:
  using Error::Error;
};

// The qualities `bidex collect` writes (issue: random, replay, medium, expert, medium-expert).
const std::vector<std::string>& qualities();

// What metadata.json holds.
struct DatasetInfo {
  std::string dataset_id;        // "hand_over/expert-v0" (Minari: env_name/dataset_name-vN)
  std::string task;              // the task id (tasks::TaskSpec::id)
  std::string task_version;      // its versioned id (tasks::TaskSpec::versioned_id)
  std::string quality;           // one of qualities()
  int64_t obs_dim = 0, act_dim = 0;
  int max_episode_steps = 0;     // the task's time limit in control steps
  double ref_min_score = NAN;    // the random policy's mean return: normalised score 0
  double ref_max_score = NAN;    // online PPO's (the expert's) mean return: normalised score 100
  std::string policy;            // what acted: "random", or a checkpoint path
  std::string algorithm_name;    // "random", "ppo", ...
  uint64_t seed = 0;
  std::string code_version;      // core/version.h
  std::string command;           // the command line that wrote it
  std::vector<std::string> sources;  // a merge (medium-expert): "ID sha256:HEX" of each input
  // written by DatasetWriter::finish
  int64_t total_steps = 0, total_episodes = 0;
  int64_t dropped_episodes = 0;  // episodes the writer refused (non-finite values)
  std::string checksum;          // "sha256:" + 64 hex digits of data/main_data.hdf5
};

// The folder of a dataset given as the folder, its data/ folder or its main_data.hdf5 file
// (bidex train --dataset accepts any of them).
std::string dataset_dir(const std::string& path);

// Writes a new dataset folder episode by episode.
class DatasetWriter {
 public:
  // `dir` must not exist or be an empty folder (a DatasetError otherwise: nothing there is
  // touched). info.obs_dim and info.act_dim must be > 0.
  DatasetWriter(const std::string& dir, const DatasetInfo& info);
  ~DatasetWriter();  // without finish(): the temporary folder is removed
  DatasetWriter(const DatasetWriter&) = delete;
  DatasetWriter& operator=(const DatasetWriter&) = delete;

  // One episode of `steps` >= 1 steps: observations (steps + 1) x obs_dim (the last row is the
  // observation after the last step), actions steps x act_dim, rewards, terminations and
  // truncations `steps` each (0 or 1; at most the last step may have either). Returns false and
  // writes nothing (counting it in dropped_episodes) when any value is not finite.
  bool add_episode(const float* observations, const float* actions, const float* rewards,
                   const uint8_t* terminations, const uint8_t* truncations, int64_t steps);
  int64_t steps() const;
  int64_t episodes() const;

  // Closes the file, computes its checksum, writes metadata.json and renames the folder into
  // place. Returns the final info.
  DatasetInfo finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// metadata.json of a dataset, checked against main_data.hdf5's structure: every episode group
// has the five arrays with consistent shapes and widths, and the totals match. A missing file,
// unparsable JSON, a missing key, a truncated or non-HDF5 file, or a shape that does not fit is
// a DatasetError naming the file and the problem. The checksum is not recomputed (verify()).
DatasetInfo read_info(const std::string& path);

// read_info() and the SHA-256 of main_data.hdf5 recomputed and compared with metadata.json's.
DatasetInfo verify(const std::string& path);

// Every transition of a dataset, for learning. Observations are stored once per episode (T+1
// rows); transition i's observation is row obs_row[i] and its next observation row obs_row[i]+1.
struct Transitions {
  DatasetInfo info;
  int64_t steps = 0;                  // N transitions
  std::vector<float> observations;    // (N + episodes) x obs_dim, episode after episode
  std::vector<float> actions;         // N x act_dim
  std::vector<float> rewards;         // N
  std::vector<uint8_t> terminations;  // N
  std::vector<uint8_t> truncations;   // N
  std::vector<int64_t> obs_row;       // N
};

// Reads a dataset (after verify() when `check_sum`, else read_info()).
Transitions load_transitions(const std::string& path, bool check_sum = true);

// D4RL's flat layout in one HDF5 file `out_file` (written atomically): observations,
// next_observations (N x obs_dim), actions (N x act_dim), rewards, terminals and timeouts (N),
// with the metadata's id, task, quality, checksum and reference scores as root attributes.
void export_d4rl(const std::string& path, const std::string& out_file);

// A new dataset at `dir` holding the episodes of each input in order (medium-expert: medium,
// then expert). The inputs must share the task and the widths (a DatasetError naming the one
// that differs) and are verified first; `info` gives the new id, quality, references and
// command; its sources list the inputs' ids and checksums.
DatasetInfo merge(const std::vector<std::string>& inputs, const std::string& dir,
                  DatasetInfo info);

}  // namespace bidex::offline
