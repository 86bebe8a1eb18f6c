#include "sim/physics.h"

#include <sstream>

#include "core/yaml.h"
#include "sim/hand_spec.h"

namespace bidex::sim {

namespace {

template <size_t N>
std::array<double, N> read_array(const YamlView& v) {
  auto xs = v.as<std::vector<double>>();
  if (xs.size() != N) v.fail("a list of " + std::to_string(N) + " numbers", v.repr());
  std::array<double, N> out{};
  for (size_t i = 0; i < N; ++i) out[i] = xs[i];
  return out;
}

void one_of(const YamlView& v, const std::string& value,
            std::initializer_list<const char*> allowed) {
  std::string list;
  for (auto a : allowed) {
    if (value == a) return;
    list += (list.empty() ? "" : ", ") + std::string(a);
  }
  v.fail("one of " + list, "'" + value + "'");
}

}  // namespace

std::string default_physics_path() { return data_dir() + "/configs/sim/physics.yaml"; }

PhysicsOptions load_physics(const std::string& path) {
  return parse_physics(YamlView::load_file(path));
}

PhysicsOptions parse_physics(const YamlView& n, PhysicsOptions o) {
  n.allow_keys({"timestep", "substeps", "integrator", "solver", "iterations", "tolerance", "cone",
                "contact_solref", "contact_solimp", "coupling_solref", "coupling_solimp",
                "gravity_free_hands", "memory", "gpu_njmax", "gpu_nconmax", "max_speed"});
  auto pos_double = [&](const char* key, double& out) {
    if (auto v = n.maybe(key)) {
      double x = v->as<double>();
      if (!(x > 0)) v->fail("a number > 0", v->repr());
      out = x;
    }
  };
  auto pos_int = [&](const char* key, int& out) {
    if (auto v = n.maybe(key)) {
      int x = v->as<int>();
      if (x <= 0) v->fail("an integer > 0", v->repr());
      out = x;
    }
  };
  pos_double("timestep", o.timestep);
  pos_int("substeps", o.substeps);
  pos_int("iterations", o.iterations);
  pos_double("tolerance", o.tolerance);
  pos_int("memory", o.memory);
  pos_int("gpu_njmax", o.gpu_njmax);
  pos_int("gpu_nconmax", o.gpu_nconmax);
  pos_double("max_speed", o.max_speed);
  if (auto v = n.maybe("integrator")) {
    o.integrator = v->as<std::string>();
    one_of(*v, o.integrator, {"Euler", "RK4"});
  }
  if (auto v = n.maybe("solver")) {
    o.solver = v->as<std::string>();
    one_of(*v, o.solver, {"Newton", "CG", "PGS"});
  }
  if (auto v = n.maybe("cone")) {
    o.cone = v->as<std::string>();
    one_of(*v, o.cone, {"pyramidal", "elliptic"});
  }
  if (auto v = n.maybe("contact_solref")) o.contact_solref = read_array<2>(*v);
  if (auto v = n.maybe("contact_solimp")) o.contact_solimp = read_array<5>(*v);
  if (auto v = n.maybe("coupling_solref")) o.coupling_solref = read_array<2>(*v);
  if (auto v = n.maybe("coupling_solimp")) o.coupling_solimp = read_array<5>(*v);
  o.gravity_free_hands = n.opt<bool>("gravity_free_hands", o.gravity_free_hands);
  return o;
}

}  // namespace bidex::sim
