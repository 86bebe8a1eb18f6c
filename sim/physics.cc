#include "sim/physics.h"

#include <algorithm>
#include <cmath>
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

// The tasks count in control steps of 1/60 s (the original's rate): a physics step whose
// substeps do not add up to one is refused, at the substeps key where the node has one.
void check_control_step(const YamlView& n, double timestep, int substeps) {
  if (std::abs(timestep * substeps - kControlDt) <= 1e-9 * kControlDt) return;
  std::ostringstream want, got;
  want << "timestep x substeps = 1/60 s (the control step), e.g. timestep "
       << kControlDt / substeps << " for " << substeps << " substeps";
  got << timestep << " x " << substeps << " = " << timestep * substeps << " s";
  auto at = n.maybe("substeps");
  if (!at) at = n.maybe("timestep");
  (at ? *at : n).fail(want.str(), got.str());
}

}  // namespace

std::string default_physics_path() { return data_dir() + "/configs/sim/physics.yaml"; }

PhysicsOptions load_physics(const std::string& path) {
  return parse_physics(YamlView::load_file(path));
}

PhysicsOptions parse_physics(const YamlView& n, PhysicsOptions o) {
  n.allow_keys({"timestep", "substeps", "integrator", "solver", "iterations", "tolerance", "cone",
                "contact_solref", "contact_solimp", "coupling_solref", "coupling_solimp", "refsafe",
                "jacobian", "gravity_free_hands", "memory", "max_speed", "gpu"});
  auto pos_double = [](const YamlView& node, const char* key, double& out) {
    if (auto v = node.maybe(key)) {
      double x = v->as<double>();
      if (!(x > 0)) v->fail("a number > 0", v->repr());
      out = x;
    }
  };
  auto pos_int = [](const YamlView& node, const char* key, int& out) {
    if (auto v = node.maybe(key)) {
      int x = v->as<int>();
      if (x <= 0) v->fail("an integer > 0", v->repr());
      out = x;
    }
  };
  pos_double(n, "timestep", o.timestep);
  pos_int(n, "substeps", o.substeps);
  // a file that gives the substeps alone keeps the control step: timestep = control step / substeps
  if (n.maybe("substeps") && !n.maybe("timestep")) o.timestep = kControlDt / o.substeps;
  check_control_step(n, o.timestep, o.substeps);
  pos_int(n, "iterations", o.iterations);
  pos_double(n, "tolerance", o.tolerance);
  pos_int(n, "memory", o.memory);
  pos_double(n, "max_speed", o.max_speed);
  if (auto v = n.maybe("integrator")) {
    o.integrator = v->as<std::string>();
    one_of(*v, o.integrator, {"Euler", "RK4", "implicit", "implicitfast", "discrete"});
  }
  if (auto v = n.maybe("solver")) {
    o.solver = v->as<std::string>();
    one_of(*v, o.solver, {"Newton", "CG", "PGS"});
  }
  if (auto v = n.maybe("cone")) {
    o.cone = v->as<std::string>();
    one_of(*v, o.cone, {"pyramidal", "elliptic"});
  }
  if (auto v = n.maybe("jacobian")) {
    o.jacobian = v->as<std::string>();
    one_of(*v, o.jacobian, {"auto", "dense", "sparse"});
  }
  if (auto v = n.maybe("contact_solref")) o.contact_solref = read_array<2>(*v);
  if (auto v = n.maybe("contact_solimp")) o.contact_solimp = read_array<5>(*v);
  if (auto v = n.maybe("coupling_solref")) o.coupling_solref = read_array<2>(*v);
  if (auto v = n.maybe("coupling_solimp")) o.coupling_solimp = read_array<5>(*v);
  o.gravity_free_hands = n.opt<bool>("gravity_free_hands", o.gravity_free_hands);
  o.refsafe = n.opt<bool>("refsafe", o.refsafe);
  if (auto g = n.maybe("gpu")) {
    g->allow_keys({"timestep", "substeps", "njmax", "nconmax", "jacobian"});
    pos_double(*g, "timestep", o.gpu.timestep);
    pos_int(*g, "substeps", o.gpu.substeps);
    if (g->maybe("substeps") && !g->maybe("timestep")) o.gpu.timestep = kControlDt / o.gpu.substeps;
    // the GPU may take other physics steps, never another control step
    if (o.gpu.timestep > 0 || o.gpu.substeps > 0) {
      const PhysicsOptions on = o.on_gpu();
      check_control_step(*g, on.timestep, on.substeps);
    }
    pos_int(*g, "njmax", o.gpu.njmax);
    pos_int(*g, "nconmax", o.gpu.nconmax);
    if (auto v = g->maybe("jacobian")) {
      o.gpu.jacobian = v->as<std::string>();
      one_of(*v, o.gpu.jacobian, {"auto", "dense", "sparse"});
    }
  }
  return o;
}

PhysicsOptions PhysicsOptions::on_gpu() const {
  PhysicsOptions o = *this;
  if (gpu.timestep > 0) o.timestep = gpu.timestep;
  if (gpu.substeps > 0) o.substeps = gpu.substeps;
  if (!gpu.jacobian.empty()) o.jacobian = gpu.jacobian;
  return o;
}

PhysicsOptions PhysicsOptions::with_gpu_room(int njmax, int nconmax) const {
  PhysicsOptions o = *this;
  o.gpu.njmax = std::max(o.gpu.njmax, njmax);
  o.gpu.nconmax = std::max(o.gpu.nconmax, nconmax);
  return o;
}

}  // namespace bidex::sim
