// Strict readers shared by the task families' YAML loaders: every failure is a ConfigError
// naming the file, the key, what was expected and what was found.
#pragma once

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

}  // namespace bidex::tasks
