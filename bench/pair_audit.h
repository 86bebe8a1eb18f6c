// The collision-pair audit of a scene: the geom pairs each world tests, as MuJoCo Warp's
// broadphase lists them (every upper-triangle geom pair that survives contype/conaffinity, the
// same weld body, dof-less pairs, parent-child filtering and <exclude>, plus the explicit
// <pair>s), counted by what they join (a hand and itself, the two hands, a hand and an object,
// ...) and by the narrowphase that takes them on the GPU (MuJoCo Warp's primitive colliders or
// its convex GJK/EPA path). `bidex bench pairs` runs it over tasks; sim/README.md reads it.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sim/model.h"

namespace bidex::bench {

// One listed pair: geom ids (g1 < g2) and the explicit <pair> it comes from (-1: none).
struct GeomPair {
  int g1 = 0, g2 = 0;
  int pair_id = -1;
};

// The pairs MuJoCo Warp's broadphase tests per world, in its order (io.py's filter).
std::vector<GeomPair> listed_pairs(const mjModel* m);

// Whether MuJoCo Warp takes geom types a and b (mjtGeom) on its convex (GJK/EPA) path; box-box
// goes there unless `native_box_box` (MuJoCo's NATIVECCD disabled: its box-box collider).
bool convex_path(int type_a, int type_b, bool native_box_box = false);

// The audit of one compiled scene: {"geoms", "pairs_upper_triangle", "pairs_listed",
// "by_kind": {hand_self, hand_hand, hand_object, hand_world, object_object, object_world},
// "by_types": {"capsule-box": n, ...}, "primitive", "convex", "convex_pairs": [names]}.
nlohmann::json audit_pairs(const sim::SimModel& model, bool native_box_box = false);

struct PairAuditConfig {
  std::vector<std::string> tasks;  // empty: every task
  std::string physics_file;        // empty: default
  bool on_gpu = true;              // the scenes as the GPU backend builds them
};

nlohmann::json run_pair_audit(const PairAuditConfig& cfg);

}  // namespace bidex::bench
