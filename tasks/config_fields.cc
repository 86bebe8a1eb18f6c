#include "tasks/config_fields.h"

#include <array>

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

}  // namespace bidex::tasks
