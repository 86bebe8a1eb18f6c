// sim/physics: physics YAML files are read strictly (unknown keys and bad values are errors).
#include "sim/physics.h"

#include <catch2/catch.hpp>

#include "core/files.h"
#include "core/yaml.h"
#include "tests/fixture.h"

using namespace bidex;
using namespace bidex::sim;
using bidex::test::check_config_error;
using bidex::test::config_error;
using bidex::test::TempDir;

TEST_CASE("the project's physics.yaml loads into valid options", "[sim][physics]") {
  PhysicsOptions p = load_physics(default_physics_path());
  CHECK(p.timestep > 0);
  CHECK(p.substeps >= 1);
  CHECK(p.control_dt() == Approx(p.timestep * p.substeps));
  // every key of the file is one the parser knows: re-reading the file alone gives the same
  auto root = YamlView::load_file(default_physics_path());
  PhysicsOptions again = parse_physics(root, PhysicsOptions{});
  CHECK(again.timestep == p.timestep);
  CHECK(again.solver == p.solver);
  CHECK(again.coupling_solref == p.coupling_solref);
}

TEST_CASE("parse_physics reads every key and keeps defaults for absent ones", "[sim][physics]") {
  auto v = YamlView::load_string(R"(timestep: 0.004166666666666667
substeps: 4
integrator: discrete
solver: PGS
iterations: 7
tolerance: 1.0e-6
cone: elliptic
jacobian: dense
contact_solref: [0.02, 0.9]
contact_solimp: [0.9, 0.95, 0.002, 0.4, 3.0]
coupling_solref: [0.003, 1.1]
coupling_solimp: [0.98, 0.997, 0.0005, 0.6, 2.5]
gravity_free_hands: false
memory: 654321
max_speed: 321.5
)",
                                 "all.yaml");
  PhysicsOptions p = parse_physics(v);
  CHECK(p.timestep == 0.004166666666666667);
  CHECK(p.substeps == 4);
  CHECK(p.control_dt() == Approx(1.0 / 60.0));
  CHECK(p.integrator == "discrete");
  CHECK(p.solver == "PGS");
  CHECK(p.iterations == 7);
  CHECK(p.tolerance == 1.0e-6);
  CHECK(p.cone == "elliptic");
  CHECK(p.jacobian == "dense");
  CHECK(p.contact_solref == std::array<double, 2>{0.02, 0.9});
  CHECK(p.contact_solimp == std::array<double, 5>{0.9, 0.95, 0.002, 0.4, 3.0});
  CHECK(p.coupling_solref == std::array<double, 2>{0.003, 1.1});
  CHECK(p.coupling_solimp == std::array<double, 5>{0.98, 0.997, 0.0005, 0.6, 2.5});
  CHECK(p.gravity_free_hands == false);
  CHECK(p.memory == 654321);
  CHECK(p.max_speed == 321.5);

  PhysicsOptions base;
  base.iterations = 99;
  PhysicsOptions partial = parse_physics(YamlView::load_string("iterations: 7\n", "p.yaml"), base);
  CHECK(partial.iterations == 7);
  CHECK(partial.substeps == base.substeps);   // untouched
  CHECK(partial.timestep == base.timestep);
  CHECK(partial.solver == base.solver);
  // the substeps alone keep the control step: the timestep follows them
  PhysicsOptions two = parse_physics(YamlView::load_string("substeps: 2\n", "p.yaml"), base);
  CHECK(two.substeps == 2);
  CHECK(two.timestep == Approx(1.0 / 120.0));
  CHECK(two.iterations == 99);  // from `base`
}

TEST_CASE("the GPU block replaces the physics step and room for the GPU backend only",
          "[sim][physics]") {
  auto v = YamlView::load_string(R"(timestep: 0.0020833333333333333
substeps: 8
gpu:
  timestep: 0.004166666666666667
  substeps: 4
  njmax: 96
  nconmax: 32
  jacobian: dense
)",
                                 "gpu.yaml");
  PhysicsOptions p = parse_physics(v);
  CHECK(p.timestep == 0.0020833333333333333);  // the CPU's step is untouched
  CHECK(p.substeps == 8);
  CHECK(p.gpu.njmax == 96);
  CHECK(p.gpu.nconmax == 32);
  PhysicsOptions g = p.on_gpu();
  CHECK(g.timestep == 0.004166666666666667);
  CHECK(g.substeps == 4);
  CHECK(g.jacobian == "dense");
  CHECK(p.jacobian == "auto");
  CHECK(g.control_dt() == Approx(p.control_dt()));
  CHECK(g.solver == p.solver);  // everything else is the CPU's
  // without a step of its own, the GPU steps the CPU's
  PhysicsOptions same = parse_physics(YamlView::load_string("gpu:\n  njmax: 64\n", "g.yaml"));
  CHECK(same.on_gpu().timestep == same.timestep);
  CHECK(same.on_gpu().substeps == same.substeps);
  CHECK(same.gpu.njmax == 64);
  // the GPU's substeps alone keep the control step
  PhysicsOptions two = parse_physics(YamlView::load_string("gpu:\n  substeps: 2\n", "g2.yaml"));
  CHECK(two.on_gpu().timestep == Approx(1.0 / 120.0));
  CHECK(two.timestep == Approx(1.0 / 480.0));

  // a step that is not the control step of 1/60 s is refused, naming the key, the control step
  // and the step given, on the CPU and on the GPU
  TempDir dir;
  const std::string path = dir.file("physics.yaml");
  write_file_atomic(path, "timestep: 0.002\nsubsteps: 8\n");
  check_config_error(config_error([&] { load_physics(path); }), path, "substeps",
                     "timestep x substeps = 1/60 s (the control step), e.g. timestep 0.00208333",
                     "0.002 x 8 = 0.016 s");
  write_file_atomic(path, "timestep: 0.004\n");  // with the default 8 substeps
  check_config_error(config_error([&] { load_physics(path); }), path, "timestep",
                     "timestep x substeps = 1/60 s", "0.004 x 8 = 0.032 s");
  write_file_atomic(path, "gpu:\n  timestep: 0.004\n  substeps: 2\n");
  check_config_error(config_error([&] { load_physics(path); }), path, "gpu.substeps",
                     "timestep x substeps = 1/60 s (the control step), e.g. timestep 0.00833333",
                     "0.004 x 2 = 0.008 s");
  write_file_atomic(path, "gpu:\n  timestep: 0.004166666666666667\n");  // with the CPU's 8
  check_config_error(config_error([&] { load_physics(path); }), path, "gpu.timestep",
                     "timestep x substeps = 1/60 s", "0.00416667 x 8 = 0.0333333 s");
  write_file_atomic(path, "gpu:\n  rows: 64\n");
  check_config_error(config_error([&] { load_physics(path); }), path, "gpu.rows",
                     "one of the keys {timestep, substeps, njmax, nconmax, jacobian}",
                     "unknown key 'rows'");
  write_file_atomic(path, "gpu:\n  njmax: 0\n");
  check_config_error(config_error([&] { load_physics(path); }), path, "gpu.njmax",
                     "an integer > 0", "0");
}

TEST_CASE("a scene's GPU room is raised to what it asks and never lowered", "[sim][physics]") {
  PhysicsOptions p = parse_physics(YamlView::load_string("gpu:\n  njmax: 192\n  nconmax: 64\n",
                                                         "room.yaml"));
  PhysicsOptions more = p.with_gpu_room(320);
  CHECK(more.gpu.njmax == 320);
  CHECK(more.gpu.nconmax == 64);  // contacts untouched unless asked
  CHECK(more.timestep == p.timestep);
  CHECK(more.memory == p.memory);
  PhysicsOptions both = p.with_gpu_room(448, 128);
  CHECK(both.gpu.njmax == 448);
  CHECK(both.gpu.nconmax == 128);
  // a physics YAML that already gives more keeps it
  PhysicsOptions roomy = parse_physics(YamlView::load_string("gpu:\n  njmax: 512\n", "roomy.yaml"));
  CHECK(roomy.with_gpu_room(320).gpu.njmax == 512);
  CHECK(p.gpu.njmax == 192);  // the options it was made from are unchanged
}

TEST_CASE("bad physics YAML is a ConfigError naming file, key, expected and actual",
          "[sim][physics]") {
  TempDir dir;
  const std::string base = read_file(default_physics_path());
  std::string path = dir.file("physics.yaml");
  // replaces the whole line that sets `key` (the file's values are tuned by others: match the key
  // only), or appends `line` when `key` is empty
  auto load_edited = [&](const std::string& key, const std::string& line) {
    std::string text = base;
    if (key.empty()) {
      text += "\n" + line + "\n";
    } else {
      size_t at = text.rfind("\n" + key + ":");
      INFO("physics.yaml sets " << key);
      REQUIRE(at != std::string::npos);
      size_t end = text.find('\n', at + 1);
      text.replace(at + 1, end == std::string::npos ? std::string::npos : end - at - 1, line);
    }
    write_file_atomic(path, text);
    return config_error([&] { load_physics(path); });
  };

  // what is wrong, the key to replace ("" appends), the new line, and the error expected
  struct Case {
    const char* what;
    const char* key;
    const char* line;
    const char* error_key;
    const char* expected;
    const char* actual;
  };
  const Case cases[] = {
      {"an unknown key", "", "substep_count: 4", "substep_count",
       "one of the keys {timestep, substeps", "unknown key 'substep_count'"},
      {"a solver MuJoCo does not have", "solver", "solver: Gauss", "solver",
       "one of Newton, CG, PGS", "'Gauss'"},
      {"an unknown integrator", "integrator", "integrator: verlet", "integrator",
       "one of Euler, RK4, implicit, implicitfast, discrete", "'verlet'"},
      {"an unknown Jacobian layout", "jacobian", "jacobian: banded", "jacobian",
       "one of auto, dense, sparse", "'banded'"},
      {"a negative timestep", "timestep", "timestep: -0.004", "timestep", "a number > 0",
       "-0.004"},
      {"zero substeps", "substeps", "substeps: 0", "substeps", "an integer > 0", "0"},
      {"a fractional iteration count", "iterations", "iterations: 2.5", "iterations",
       "an integer", "2.5"},
      {"a solref of the wrong length", "coupling_solref", "coupling_solref: [0.005]",
       "coupling_solref", "a list of 2 numbers", "[0.005]"},
      {"a string inside solimp", "contact_solimp",
       "contact_solimp: [0.95, high, 0.001, 0.5, 2.0]", "contact_solimp[1]", "a number", "high"},
      {"a string where a boolean is expected", "gravity_free_hands",
       "gravity_free_hands: sometimes", "gravity_free_hands", "true or false", "sometimes"},
  };
  for (const Case& c : cases) {
    SECTION(c.what) {
      auto e = load_edited(c.key, c.line);
      check_config_error(e, path, c.error_key, c.expected, c.actual);
    }
  }
}
