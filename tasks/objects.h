// The objects a task can be configured with: the original's egg, block and pen, a ball, or a
// user's MJCF body file. YAML: `object: egg`, or a map
//   object: {type: ball, size: [0.035], density: 500, friction: 1}
//   object: {type: mjcf, file: my_object.xml}   # the inside of a <body> element; path relative
//                                               # to the YAML file
#pragma once

#include <string>

#include "sim/batch.h"
#include "sim/scene.h"
#include "tasks/object_body.h"
#include "tasks/spec.h"

namespace bidex {
class YamlView;
}

namespace bidex::tasks {

struct ObjectChoice {
  std::string type;     // egg, block, pen, ball or mjcf
  sim::ObjectSpec spec; // shape, size, mass, damping, friction (name and pose are the task's)
  std::string file;     // mjcf: where the body came from
  double density = 0;   // kg/m^3 of the primitive shapes (0 for mjcf)
};

// The preset of a type (egg, block, pen, ball); throws ConfigError listing the types.
ObjectChoice object_preset(const std::string& type, const std::string& file = "",
                           const std::string& key = "object");
// Reads `object:` from a task YAML (a type name or a map, see above).
ObjectChoice parse_object(const YamlView& v);
// A goal marker drawn like the object (an mjcf object gets a small sphere), never colliding.
sim::ObjectSpec goal_marker(const ObjectChoice& object, const std::string& name);
// Radius of the smallest sphere about the object's origin that holds it (0 for mjcf objects).
double bounding_radius(const sim::ObjectSpec& o);
// The object block of an observation (13 values): position 3, orientation (x, y, z, w) 4, linear
// velocity 3, angular velocity x 0.2 3, of a body whose tree's root body is `root_tree`.
void observe_object(const sim::SlotView& v, int body, int root_tree, float* out);
// Their layouts: `<name>.pose` 7, `.linvel` 3, `.angvel` 3, with `what` (e.g. "the pot") in the
// docs; and `<name>.pose` 7, `.rot_diff` 4, both goal slices (masked in meta-RL), `goal_doc`
// saying what the goal pose is and `rot_doc` whose orientation the difference takes (default:
// the object's).
void add_object_obs(Layout& obs, const std::string& name, const std::string& what);
void add_goal_obs(Layout& obs, const std::string& name, const std::string& goal_doc,
                  const std::string& rot_doc = "");
// The goal block (11 values): goal position 3, goal orientation 4, then the quaternion difference
// object * conj(goal) 4 (orientations written (x, y, z, w)); `goal` is position then (w, x, y, z).
void observe_goal(const double* goal, const double* object_quat, float* out);

// Volume (m^3) of a primitive object.
double object_volume(const sim::ObjectSpec& o);

}  // namespace bidex::tasks
