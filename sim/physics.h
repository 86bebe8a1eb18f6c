// Physics settings of a scene: chosen by measurement (sim/README.md), kept in
// configs/sim/physics.yaml, overridable per task.
#pragma once

#include <array>
#include <string>

namespace bidex {
class YamlView;
}

namespace bidex::sim {

struct PhysicsOptions {
  double timestep = 1.0 / 240.0;  // s per physics step
  int substeps = 4;               // physics steps per control step (60 Hz control)
  std::string integrator = "Euler";  // Euler (implicit joint damping) or RK4
  std::string solver = "Newton";     // Newton, CG or PGS
  int iterations = 20;               // main solver iterations
  double tolerance = 1e-8;           // solver early-exit tolerance
  std::string cone = "pyramidal";    // friction cone: pyramidal or elliptic
  std::array<double, 2> contact_solref{0.01, 1.0};             // time constant (s), damping ratio
  std::array<double, 5> contact_solimp{0.95, 0.99, 0.001, 0.5, 2.0};
  std::array<double, 2> coupling_solref{0.005, 1.0};           // distal-middle coupling
  std::array<double, 5> coupling_solimp{0.99, 0.999, 0.001, 0.5, 2.0};
  bool gravity_free_hands = true;  // hands carry no weight, as in the original
  int njmax = 300;    // constraint rows per world (limits, couplings, contacts)
  int nconmax = 80;   // contacts per world
  int nstack = 60000; // mjData stack (mjtNums) per world
  double max_speed = 1000.0;  // a |qvel| above this (m/s or rad/s) is an exploded slot

  double control_dt() const { return timestep * substeps; }
};

// Reads a physics YAML (unknown keys and bad values are ConfigErrors); keys not in the file
// keep their defaults.
PhysicsOptions parse_physics(const YamlView& node, PhysicsOptions base = {});
PhysicsOptions load_physics(const std::string& path);
// configs/sim/physics.yaml
std::string default_physics_path();

}  // namespace bidex::sim
