// Physics settings of a scene: chosen by measurement (sim/README.md), kept in
// configs/sim/physics.yaml, overridable per task.
#pragma once

#include <array>
#include <string>

namespace bidex {
class YamlView;
}

namespace bidex::sim {

// The control step: the tasks' and the policy's rate (60 Hz, the original's). Every physics
// step (timestep x substeps) adds up to it; parse_physics refuses one that does not.
inline constexpr double kControlDt = 1.0 / 60.0;

struct PhysicsOptions {
  double timestep = 1.0 / 480.0;  // s per physics step
  int substeps = 8;               // physics steps per control step (60 Hz control)
  // Euler (implicit joint damping), implicitfast, implicit, discrete (constraint springs at the
  // end of the step: contacts stiffer than 2 timesteps stay stable) or RK4
  std::string integrator = "Euler";
  std::string solver = "Newton";     // Newton, CG or PGS
  int iterations = 20;               // main solver iterations (a cap)
  double tolerance = 1e-8;           // solver early-exit tolerance
  std::string cone = "pyramidal";    // friction cone: pyramidal or elliptic
  // MuJoCo's REFSAFE: constraint time constants below the integrator's floor are raised to it
  // (2 timesteps; with discrete, where the step cannot resolve the spring); false lets them be
  bool refsafe = true;
  std::string jacobian = "auto";     // constraint Jacobian: auto (dense below 60 dofs), dense,
                                     // sparse
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
  double max_speed = 1000.0;  // a |qvel| above this (m/s or rad/s) is an exploded slot

  // What the GPU backend (MuJoCo Warp, float32) does differently (sim/README.md, "Physics on
  // the GPU"): its own step, and its room per world, which MuJoCo Warp allocates up front
  struct Gpu {
    double timestep = 0;  // s per physics step (0: the CPU's timestep)
    int substeps = 0;     // (0: the CPU's substeps); the control step must stay the CPU's
    int njmax = 192;      // constraint rows per world; a world that needs more is reset
    int nconmax = 64;     // contacts per world (a pool shared by all worlds)
    std::string jacobian;  // (empty: the CPU's)
  } gpu;

  double control_dt() const { return timestep * substeps; }
  // These options as the GPU backend steps them: timestep, substeps and jacobian replaced by
  // gpu's.
  PhysicsOptions on_gpu() const;
  // These options with the GPU room per world raised to at least `njmax` constraint rows and
  // `nconmax` contacts (never lowered): a scene whose worlds need more than the default asks
  // for it in its scene(), with the measurement in a comment there
  PhysicsOptions with_gpu_room(int njmax, int nconmax = 0) const;
};

// Reads a physics YAML (unknown keys and bad values are ConfigErrors); keys not in the file
// keep their defaults.
PhysicsOptions parse_physics(const YamlView& node, PhysicsOptions base = {});
PhysicsOptions load_physics(const std::string& path);
// configs/sim/physics.yaml
std::string default_physics_path();

}  // namespace bidex::sim
