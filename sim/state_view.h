// The rows of one world that task stages read and write, for either backend: the CPU batch
// (float64 rows of SimBatch and the slot's mjData) and MuJoCo Warp on the GPU (float32 rows of
// its world-major arrays). Task stage bodies are templates over `Real` written once for host and
// device (core/hd.h); they see plain arrays only, never MuJoCo types.
//
// Layouts are MuJoCo's: positions (x, y, z), quaternions (w, x, y, z), spatial velocities
// (rotation, translation) about the subtree centre of mass of the body's tree root.
#pragma once

namespace bidex::sim {

template <class Real>
struct WorldRows {
  // state after physics (read by evaluate and observe)
  const Real* qpos = nullptr;             // nq
  const Real* qvel = nullptr;             // nv
  const Real* qfrc_actuator = nullptr;    // nv
  const Real* qfrc_constraint = nullptr;  // nv
  const Real* sensordata = nullptr;       // nsensordata
  const Real* xpos = nullptr;             // nbody x 3
  const Real* xquat = nullptr;            // nbody x 4
  const Real* cvel = nullptr;             // nbody x 6
  const Real* subtree_com = nullptr;      // nbody x 3
  // inputs (written by apply_actions)
  Real* ctrl = nullptr;                   // nu: actuator targets (rad)
  Real* base_wrench = nullptr;            // nwrench: force (N) and torque (N m) per hand base
  // goal markers (mocap bodies), moved by evaluate when a task draws new goals mid-episode
  Real* mocap_pos = nullptr;              // nmocap x 3
  Real* mocap_quat = nullptr;             // nmocap x 4
};

// What a reset writes before the backend's position pass: the generalized state, the actuator
// targets and the goal markers (mocap bodies).
template <class Real>
struct ResetRows {
  Real* qpos = nullptr;        // nq
  Real* qvel = nullptr;        // nv
  Real* ctrl = nullptr;        // nu
  Real* mocap_pos = nullptr;   // nmocap x 3
  Real* mocap_quat = nullptr;  // nmocap x 4
};

}  // namespace bidex::sim
