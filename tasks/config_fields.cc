#include "tasks/config_fields.h"

#include <array>
#include <string>

namespace bidex::tasks {

double read_number(const YamlView& parent, const char* key, double lo, double hi,
                   const char* what) {
  auto v = parent.child(key);
  const double x = v.as<double>();
  if (!(x >= lo && x <= hi)) v.fail(what, v.repr());
  return x;
}

sim::Vec3 read_vec3(const YamlView& v) { return v.as<std::array<double, 3>>(); }

HandPose read_hand_pose(const YamlView& v) {
  v.allow_keys({"pos", "rpy"});
  HandPose h;
  h.pos = read_vec3(v.child("pos"));
  h.rpy = read_vec3(v.child("rpy"));
  return h;
}

int read_episode_length(const YamlView& root) {
  auto v = root.child("episode_length");
  const int n = v.as<int>();
  if (n <= 0) v.fail("an episode length > 0 (control steps)", v.repr());
  return n;
}

void read_hand_poses(const YamlView& root, HandPose* right, HandPose* left) {
  auto h = root.child("hands");
  h.allow_keys({"right", "left"});
  *right = read_hand_pose(h.child("right"));
  *left = read_hand_pose(h.child("left"));
}

void read_base_scales(const YamlView& root, double* force_scale, double* torque_scale) {
  auto b = root.child("base");
  b.allow_keys({"force_scale", "torque_scale"});
  *force_scale = read_number(b, "force_scale", 0, 10, "a scale in [0, 10] (x 1e5/60 N)");
  *torque_scale = read_number(b, "torque_scale", 0, 100, "a scale in [0, 100] (x 1e3/60 N m)");
}

RewardVariants read_reward_variants(const YamlView& reward, const std::string& own) {
  reward.expect_map();
  if (!reward.has("variant")) return {reward, reward, false, "", {}};
  // which variant the section's own values are (`own`, else the one without the map)
  const bool has_paper = reward.has("paper"), has_original = reward.has("original");
  if (has_paper == has_original)
    reward.fail("a map of the other variant's values, 'paper' or 'original' (one), beside "
                "'variant'",
                has_paper ? "both" : "neither");
  const std::string other_name = has_paper ? "paper" : "original";
  const std::string base_name = !own.empty() ? own : has_paper ? "original" : "paper";
  auto v = reward.child("variant");
  const auto variant = v.as<std::string>();
  if (variant != base_name && variant != other_name)
    v.fail("'" + base_name + "' or '" + other_name + "'", v.repr());
  // the map's values over the section's; each must replace one of them
  auto map = reward.child(other_name);
  map.expect_map();
  YAML::Node other = YAML::Clone(reward.node());
  other.remove("variant");
  other.remove(other_name);
  for (const auto& key : map.keys()) {
    if (key == "variant" || !other[key])
      map.child(key).fail("a key of '" + reward.path() + "' (the " + other_name +
                              " variant replaces its values)",
                          "'" + key + "', which '" + reward.path() + "' does not have");
    other[key] = YAML::Clone(map.node()[key]);
  }
  // copies have no line numbers: the file and the map's key path name the place
  const YamlView o(other, reward.file(), map.path(), /*lines=*/false);
  return {reward, o, variant != base_name, variant, {"variant", other_name}};
}

}  // namespace bidex::tasks
