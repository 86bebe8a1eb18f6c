// Suites as data: configs/suites/<ID>.yaml (MT1, ML1, MT4, ML4, MT20, ML20), each a list of
// train entries and test entries (task, label, task YAML with goal parameters, reward scale) and
// a mode: multitask (one-hot entry id) or meta (goal slices masked). Read strictly: unknown keys,
// missing fields, unknown tasks and duplicate labels are ConfigErrors naming file and key.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "taskpack/pack.h"

namespace bidex::taskpack {

struct SuiteEntry {
  std::string task;           // task or variant id
  std::string label;          // unique within the suite (default: task)
  std::string config;         // task YAML, resolved to a path (empty: the task's default)
  double reward_scale = 1.0;
  // A goal distribution: `goals: {count: N, half_extent: [x, y, z]}` draws N goal shifts
  // uniform in the box +-half_extent (m) around the task's goal, from the suite's goal_seed (the
  // train entries' draws first, then the test entries', so held-out goals are new draws). The
  // pack's slots take them in turn (PackEntry::goals); empty: the configured goal.
  std::vector<std::array<double, 3>> goals;
};

struct Suite {
  std::string id;             // "MT4"
  std::string file;           // the YAML it came from
  std::string description;
  std::string source;         // where the definition comes from, in words
  PackMode mode = PackMode::kMultiTask;
  std::vector<SuiteEntry> train;
  std::vector<SuiteEntry> test;   // multi-task suites: the train entries
  bool test_is_train = false;      // `test: train`: no held-out tasks (every multi-task suite)
  // Whether its test split holds tasks the train split does not (what meta-RL needs).
  bool held_out() const { return mode == PackMode::kMeta && !test_is_train; }
  uint64_t goal_seed = 0;          // the goal distributions' stream (required with `goals`)
};

// The ids of the suite files under <data dir>/configs/suites, in the paper's order.
std::vector<std::string> known_suites();
// Those of them whose test split is held out (Suite::held_out, meta-RL's), or with `held_out`
// false the others (the multi-task suites), for messages: "ML1, ML4, ...".
std::string known_suites_text(bool held_out);
// A suite by id ("MT4", looked up under configs/suites) or by path to a YAML file.
Suite load_suite(const std::string& id_or_file);
// The pack of one split ("train" or "test") with `total_slots` spread evenly over its entries
// (the first total_slots % n entries get one more). Observation and action pads are the widest
// over both splits, so that a policy trained on one split runs on the other; the one-hot width
// is the number of train entries.
PackSpec suite_pack(const Suite& suite, const std::string& split, int total_slots);

}  // namespace bidex::taskpack
