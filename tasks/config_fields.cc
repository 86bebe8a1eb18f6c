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

}  // namespace bidex::tasks
