#include "bench/pair_audit.h"

#include <algorithm>
#include <map>

#include <mujoco/mujoco.h>

#include "core/error.h"
#include "tasks/env.h"
#include "tasks/registry.h"

namespace bidex::bench {

using nlohmann::json;

std::vector<GeomPair> listed_pairs(const mjModel* m) {
  // explicit <pair>s by geom pair
  std::map<std::pair<int, int>, int> explicit_pair;
  for (int i = 0; i < m->npair; ++i) {
    int a = m->pair_geom1[i], b = m->pair_geom2[i];
    explicit_pair[{std::min(a, b), std::max(a, b)}] = i;
  }
  const bool filterparent = !(m->opt.disableflags & mjDSBL_FILTERPARENT);
  auto excluded = [&](int b1, int b2) {
    const int sig = (b1 << 16) + b2;
    for (int i = 0; i < m->nexclude; ++i)
      if (m->exclude_signature[i] == sig) return true;
    return false;
  };
  std::vector<GeomPair> out;
  for (int g1 = 0; g1 < m->ngeom; ++g1)
    for (int g2 = g1 + 1; g2 < m->ngeom; ++g2) {
      auto it = explicit_pair.find({g1, g2});
      if (it != explicit_pair.end()) {
        out.push_back({g1, g2, it->second});
        continue;
      }
      // the filter of MuJoCo Warp's io.py (MuJoCo's filterBodyPair and contype/conaffinity)
      const int b1 = m->geom_bodyid[g1], b2 = m->geom_bodyid[g2];
      const int w1 = m->body_weldid[b1], w2 = m->body_weldid[b2];
      const int wp1 = m->body_weldid[m->body_parentid[w1]];
      const int wp2 = m->body_weldid[m->body_parentid[w2]];
      const bool mask = (m->geom_contype[g1] & m->geom_conaffinity[g2]) ||
                        (m->geom_contype[g2] & m->geom_conaffinity[g1]);
      const bool same = w1 == w2;
      const bool no_dofs = m->body_dofnum[w1] == 0 && m->body_dofnum[w2] == 0;
      const bool parent_child = filterparent && w1 != 0 && w2 != 0 && (w1 == wp2 || w2 == wp1);
      if (mask && !same && !no_dofs && !parent_child && !excluded(b1, b2))
        out.push_back({g1, g2, -1});
    }
  return out;
}

bool convex_path(int a, int b, bool native_box_box) {
  if (a > b) std::swap(a, b);
  // MuJoCo Warp's MJ_COLLISION_TABLE (collision_driver.py): what is not primitive is convex
  if (a == mjGEOM_PLANE) return false;
  if (a == mjGEOM_HFIELD) return true;
  if (b == mjGEOM_ELLIPSOID || b == mjGEOM_MESH || a == mjGEOM_ELLIPSOID) return true;
  if (a == mjGEOM_SPHERE) return false;  // sphere with sphere, capsule, cylinder, box
  if (a == mjGEOM_CAPSULE) return b == mjGEOM_CYLINDER;  // capsule-capsule, capsule-box primitive
  if (a == mjGEOM_CYLINDER) return true;                 // cylinder-cylinder, cylinder-box
  if (a == mjGEOM_BOX && b == mjGEOM_BOX) return !native_box_box;
  return true;
}

namespace {

const char* type_name(int t) {
  switch (t) {
    case mjGEOM_PLANE: return "plane";
    case mjGEOM_HFIELD: return "hfield";
    case mjGEOM_SPHERE: return "sphere";
    case mjGEOM_CAPSULE: return "capsule";
    case mjGEOM_ELLIPSOID: return "ellipsoid";
    case mjGEOM_CYLINDER: return "cylinder";
    case mjGEOM_BOX: return "box";
    case mjGEOM_MESH: return "mesh";
    default: return "other";
  }
}

}  // namespace

json audit_pairs(const sim::SimModel& model, bool native_box_box) {
  const mjModel* m = model.mj();
  // the owner of each geom: a hand (0, 1, ...), the world (static geoms), or an object
  constexpr int kWorld = -1, kObject = -2;
  std::vector<int> owner(m->ngeom, kObject);
  for (int g = 0; g < m->ngeom; ++g) {
    const int b = m->geom_bodyid[g];
    if (m->body_weldid[b] == 0) owner[g] = kWorld;
    for (size_t h = 0; h < model.hands().size(); ++h) {
      const auto& bodies = model.hands()[h].bodies;
      if (std::find(bodies.begin(), bodies.end(), b) != bodies.end()) owner[g] = static_cast<int>(h);
    }
  }
  auto kind = [&](int a, int b) -> const char* {
    if (a >= 0 && b >= 0) return a == b ? "hand_self" : "hand_hand";
    if (a >= 0 || b >= 0) {
      const int other = a >= 0 ? b : a;
      return other == kWorld ? "hand_world" : "hand_object";
    }
    if (a == kWorld || b == kWorld) return "object_world";
    return "object_object";
  };
  json by_kind = {{"hand_self", 0},   {"hand_hand", 0},     {"hand_object", 0},
                  {"hand_world", 0},  {"object_object", 0}, {"object_world", 0}};
  json by_types = json::object(), convex_by_kind = json::object();
  int primitive = 0, convex = 0;
  const auto pairs = listed_pairs(m);
  for (const GeomPair& p : pairs) {
    const char* k = kind(owner[p.g1], owner[p.g2]);
    by_kind[k] = by_kind[k].get<int>() + 1;
    int t1 = m->geom_type[p.g1], t2 = m->geom_type[p.g2];
    if (t1 > t2) std::swap(t1, t2);
    const std::string tn = std::string(type_name(t1)) + "-" + type_name(t2);
    by_types[tn] = by_types.value(tn, 0) + 1;
    if (convex_path(t1, t2, native_box_box)) {
      ++convex;
      convex_by_kind[k] = convex_by_kind.value(k, 0) + 1;
    } else {
      ++primitive;
    }
  }
  return {{"geoms", m->ngeom},
          {"pairs_upper_triangle", static_cast<int64_t>(m->ngeom) * (m->ngeom - 1) / 2},
          {"pairs_listed", static_cast<int>(pairs.size())},
          {"explicit_pairs", m->npair},
          {"by_kind", by_kind},
          {"by_types", by_types},
          {"primitive", primitive},
          {"convex", convex},
          {"convex_by_kind", convex_by_kind}};
}

json run_pair_audit(const PairAuditConfig& cfg) {
  std::vector<std::string> ids = cfg.tasks;
  if (ids.empty())
    for (auto* list : {&tasks::task_registry(), &tasks::variant_registry()})
      for (auto& e : *list) ids.push_back(e.spec().id);
  json out;
  out["what"] =
      "geom pairs each world tests per task scene, as MuJoCo Warp's broadphase lists them, by "
      "what they join and by narrowphase path";
  out["on_gpu"] = cfg.on_gpu;
  out["tasks"] = json::array();
  for (const std::string& id : ids) {
    auto task = tasks::make_task(id);
    auto model = tasks::build_task_model(*task, "", cfg.physics_file, cfg.on_gpu);
    json a = audit_pairs(*model);
    a["task"] = id;
    a["convex_native_box_box"] = audit_pairs(*model, true)["convex"];
    out["tasks"].push_back(std::move(a));
  }
  return out;
}

}  // namespace bidex::bench
