// The state of N worlds for the GPU engine: one array per field, the world as first index
// ((nworld, n) row-major), in precision T. The fields are listed once below; allocation,
// copies, memory figures and the per-world views all derive from the table.
//
// World<T> is one world's view (a pointer per field, already offset to the world's row); the
// stage functions take it, so they neither know nor care whether it points into host memory,
// device global memory or shared memory.
#pragma once

#include <cstddef>
#include <vector>

#include "sim/gpu/hd.h"
#include "sim/gpu/model.h"

namespace bidex::sim::gpu {

// Real fields: name, values per world (in Sizes `s`), who writes it. Names follow mjData.
#define BIDEX_GPU_REAL_FIELDS(X)                                                              \
  X(qpos, s.nq, "input/state: joint positions; kinematics normalises quaternions, euler advances") \
  X(qvel, s.nv, "input/state: joint velocities; euler advances")                              \
  X(ctrl, s.nu, "input: actuator controls (position targets, motor commands)")                \
  X(xfrc_applied, s.nbody * 6, "input: force (3) then torque (3) per body, world frame, at the " \
                               "centre of mass")                                              \
  X(qfrc_applied, s.nv, "input: generalized forces")                                        \
  X(qacc_warmstart, s.nv, "state: the solver's last acceleration, written by fwd_constraint")  \
  X(time, 1, "state: simulated seconds, written by euler")                                    \
  X(xpos, s.nbody * 3, "body positions, written by kinematics")                               \
  X(xquat, s.nbody * 4, "body orientations, written by kinematics")                           \
  X(xmat, s.nbody * 9, "body rotation matrices, written by kinematics")                       \
  X(xipos, s.nbody * 3, "centres of mass, written by kinematics")                             \
  X(ximat, s.nbody * 9, "principal inertia frames, written by kinematics")                    \
  X(xanchor, s.njnt * 3, "joint anchors, written by kinematics")                              \
  X(xaxis, s.njnt * 3, "joint axes, written by kinematics")                                   \
  X(geom_xpos, s.ngeom * 3, "geom positions, written by kinematics (when asked)")             \
  X(geom_xmat, s.ngeom * 9, "geom rotation matrices, written by kinematics (when asked)")     \
  X(site_xpos, s.nsite * 3, "site positions, written by kinematics (when asked)")             \
  X(site_xmat, s.nsite * 9, "site rotation matrices, written by kinematics (when asked)")     \
  X(subtree_com, s.nbody * 3, "subtree centres of mass, written by com_pos")                  \
  X(cinert, s.nbody * 10, "com-based body inertias, written by com_pos")                      \
  X(cdof, s.nv * 6, "com-based motion axes of the dofs, written by com_pos")                  \
  X(ten_length, s.ntendon, "fixed tendon lengths, written by tendon")                         \
  X(crb, s.nbody * 10, "composite inertias, written by crb")                                  \
  X(qM, s.nM, "mass matrix (tree layout, with armature), written by crb")                     \
  X(qLD, s.nM, "L'DL factor of qM, written by factor_m")                                      \
  X(qLDiagInv, s.nv, "1 / diag(D) of qLD, written by factor_m")                               \
  X(actuator_length, s.nu, "actuator lengths, written by transmission")                       \
  X(ten_velocity, s.ntendon, "tendon velocities, written by fwd_velocity")                    \
  X(actuator_velocity, s.nu, "actuator velocities, written by fwd_velocity")                  \
  X(cvel, s.nbody * 6, "com-based body velocities (rot, lin), written by com_vel")            \
  X(cdof_dot, s.nv * 6, "time derivative of cdof, written by com_vel")                        \
  X(qfrc_passive, s.nv, "spring and damper forces, written by passive")                       \
  X(rne_cacc, s.nbody * 6, "body accelerations of the bias computation, written by rne")      \
  X(rne_cfrc, s.nbody * 6, "subtree forces of the bias computation, written by rne")         \
  X(qfrc_bias, s.nv, "Coriolis, centrifugal and gravity forces, written by rne")              \
  X(actuator_force, s.nu, "actuator forces, written by fwd_actuation")                        \
  X(qfrc_actuator, s.nv, "actuator forces in joint space, written by fwd_actuation")          \
  X(qfrc_smooth, s.nv, "all forces but constraints, written by fwd_acceleration")             \
  X(qacc_smooth, s.nv, "unconstrained acceleration, written by fwd_acceleration")             \
  X(efc_J, s.ncandnnz, "constraint Jacobian nonzeros per candidate, written by make_constraint") \
  X(efc_pos, s.ncand, "constraint violation, written by make_constraint")                     \
  X(efc_imp, s.ncand, "constraint impedance, written by make_constraint")                     \
  X(efc_R, s.ncand, "constraint regulariser, written by make_constraint")                     \
  X(efc_D, s.ncand, "1 / efc_R, written by make_constraint")                                  \
  X(efc_vel, s.ncand, "J qvel, written by reference_constraint")                              \
  X(efc_aref, s.ncand, "reference acceleration, written by reference_constraint")             \
  X(efc_force, s.ncand, "constraint force, written by fwd_constraint")                        \
  X(efc_jar, s.ncand, "J qacc - aref (solver), written by fwd_constraint")                    \
  X(efc_jv, s.ncand, "J search (solver), written by fwd_constraint")                          \
  X(qacc, s.nv, "acceleration, written by fwd_constraint")                                    \
  X(qfrc_constraint, s.nv, "constraint forces, written by fwd_constraint")                    \
  X(sol_Ma, s.nv, "M qacc (solver), written by fwd_constraint")                               \
  X(sol_Mv, s.nv, "M search (solver), written by fwd_constraint")                             \
  X(sol_grad, s.nv, "cost gradient (solver), written by fwd_constraint")                      \
  X(sol_search, s.nv, "Newton direction (solver), written by fwd_constraint")                 \
  X(qH, s.nM, "L'DL factor of the solver Hessian, then of M + h diag(damping) (euler)")       \
  X(qHDiagInv, s.nv, "1 / diag(D) of qH")                                                    \
  X(qacc_euler, s.nv, "acceleration with implicit damping, written by euler")

// Integer fields.
#define BIDEX_GPU_INT_FIELDS(X)                                                               \
  X(efc_active, s.ncand, "1 where the candidate row is instantiated, written by make_constraint") \
  X(efc_state, s.ncand, "mjtConstraintState of each active row, written by fwd_constraint")   \
  X(solver_niter, 1, "solver iterations of the last step, written by fwd_constraint")         \
  X(fault, 1, "FaultBits of the world, written by the step (0: healthy)")

// Why a world is unhealthy after a step (bits of the fault field).
enum GpuFault : int {
  kGpuFaultNone = 0,
  kGpuFaultNonFinite = 1 << 0,  // non-finite qpos, qvel or qacc
  kGpuFaultBadCtrl = 1 << 1,    // non-finite ctrl (zeroed for the step, as MuJoCo does)
  kGpuFaultInertia = 1 << 2,    // a pivot of M or the Hessian fell below mjMINVAL
};

// One world's fields.
template <class T>
struct World {
#define BIDEX_X(name, count, doc) T* name;
  BIDEX_GPU_REAL_FIELDS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc) int* name;
  BIDEX_GPU_INT_FIELDS(BIDEX_X)
#undef BIDEX_X
};

// Every field of N worlds: base pointers and the per-world lengths.
template <class T>
struct Data {
  int nworld = 0;
#define BIDEX_X(name, count, doc) \
  T* name = nullptr;              \
  long name##_n = 0;
  BIDEX_GPU_REAL_FIELDS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc) \
  int* name = nullptr;            \
  long name##_n = 0;
  BIDEX_GPU_INT_FIELDS(BIDEX_X)
#undef BIDEX_X

  BIDEX_HD World<T> world(int w) const {
    World<T> v;
#define BIDEX_X(name, count, doc) v.name = name + name##_n * w;
    BIDEX_GPU_REAL_FIELDS(BIDEX_X)
    BIDEX_GPU_INT_FIELDS(BIDEX_X)
#undef BIDEX_X
    return v;
  }
};

// Bytes of the block that holds every field of `nworld` worlds (each field 16-byte aligned).
template <class T>
size_t layout_bytes(const Sizes& s, int nworld);

// Lays the fields of `nworld` worlds out in one block starting at `base` (16-byte aligned,
// layout_bytes<T>(s, nworld) long) and returns the view.
template <class T>
Data<T> layout(const Sizes& s, int nworld, std::byte* base);

// N worlds in host memory (the CI parity tests and the host engine).
template <class T>
class HostData {
 public:
  HostData(const Sizes& s, int nworld);
  const Data<T>& data() const { return data_; }
  World<T> world(int w) const { return data_.world(w); }
  size_t bytes() const { return block_.size() * sizeof(double); }

 private:
  std::vector<double> block_;  // double-aligned storage of every field
  Data<T> data_;
};

}  // namespace bidex::sim::gpu
