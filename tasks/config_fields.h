// Strict readers shared by the task families' YAML loaders: every failure is a ConfigError
// naming the file, the key, what was expected and what was found.
#pragma once

#include <string>
#include <vector>

#include "core/yaml.h"
#include "sim/model.h"

namespace bidex::tasks {

// parent[key], a number in [lo, hi]; `what` is the expected value in the error.
double read_number(const YamlView& parent, const char* key, double lo, double hi,
                   const char* what);
// [x, y, z]
sim::Vec3 read_vec3(const YamlView& v);

// A hand's mount: {pos: [x, y, z], rpy: [roll, pitch, yaw]}, R = Rz(yaw) Ry(pitch) Rx(roll).
struct HandPose {
  sim::Vec3 pos{};
  sim::Vec3 rpy{};
};
HandPose read_hand_pose(const YamlView& v);

// The head every task YAML shares, read from its root: `episode_length` (control steps, > 0),
// `hands: {right: pose, left: pose}` and `base: {force_scale, torque_scale}` (free bases: action
// +-1 gives force_scale x 1e5/60 N and torque_scale x 1e3/60 N m).
int read_episode_length(const YamlView& root);
void read_hand_poses(const YamlView& root, HandPose* right, HandPose* left);
void read_base_scales(const YamlView& root, double* force_scale, double* torque_scale);

// A reward section with two variants (tasks/README.md, "Reward variants"): `variant: original`
// (the original code's terms and constants) or `variant: paper` (the paper's printed formula).
// The section's own values are one variant's; a map named after the other variant (`paper:` or
// `original:`) holds the values that differ, each replacing one of the section's keys. `base`
// is the section itself (its readers allow the keys in `extra` beside their own); `other` is a
// copy with the map's values put over it (its path names the map, so errors name the map's
// keys); `use_other` says whether `variant` names the map's variant. A section without
// `variant` has one formula: `base` and `other` are the section itself, `extra` is empty.
// Readers read both (so that a mistake in either is an error) and keep the one chosen.
// `own` names the section's own variant where it is neither of the two (pour_water's `bidex`,
// a reward of bidex's own): the map may then be `paper` or `original`, and `variant` names
// `own` or the map.
struct RewardVariants {
  YamlView base, other;
  bool use_other = false;
  std::string variant;              // "original", "paper", or "" (no variants)
  std::vector<std::string> extra;   // {"variant", the map's name}, or none
};
RewardVariants read_reward_variants(const YamlView& reward, const std::string& own = "");

// Reads a task's parameters under both variants with `read(view, params)` (so that either's
// mistakes are errors) and keeps the chosen one in `p`, naming it in `p.reward_variant`.
template <class Params, class Read>
void read_chosen_variant(const RewardVariants& rv, Params& p, Read&& read) {
  Params other = p;
  read(rv.base, p);
  read(rv.other, other);
  if (rv.use_other) p = other;
  p.reward_variant = rv.variant;
}

}  // namespace bidex::tasks
