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
  double timestep = 1.0 / 480.0;  // s per physics step
  int substeps = 8;               // physics steps per control step (60 Hz control)
  std::string integrator = "Euler";  // Euler (implicit joint damping) or RK4
  std::string solver = "Newton";     // Newton, CG or PGS
  int iterations = 20;               // main solver iterations (a cap)
  double tolerance = 1e-8;           // solver early-exit tolerance
  std::string cone = "pyramidal";    // friction cone: pyramidal or elliptic
  // contacts, the hands' self-contact pairs included: time constant (s; MuJoCo raises it to at
  // least 2 timesteps), damping ratio; impedance
  std::array<double, 2> contact_solref{2.0 / 480.0, 1.0};
  std::array<double, 5> contact_solimp{0.99, 0.999, 0.001, 0.5, 2.0};
  std::array<double, 2> coupling_solref{2.0 / 480.0, 1.0};     // distal-middle coupling
  std::array<double, 5> coupling_solimp{0.99, 0.999, 0.001, 0.5, 2.0};
  bool gravity_free_hands = true;  // hands carry no weight, as in the original (gravcomp)
  // bytes of one world's arena (MuJoCo 3's <size memory>): contacts, constraint rows and the
  // solver's scratch; a world that fills it is a fault and a reset
  int memory = 512 << 10;
  // the GPU backend's room per world (MuJoCo Warp allocates fixed rows): constraint rows and
  // contacts; a world that needs more is a fault and a reset (sim/README.md)
  int gpu_njmax = 192;
  int gpu_nconmax = 64;
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
