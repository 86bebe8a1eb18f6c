// The GPU engine's copy of a compiled MuJoCo model: plain arrays (no MuJoCo types) that host and
// device code read alike, plus index tables computed once on the host (tree levels, child lists,
// the mass matrix's column lists, the constraint candidates and their Jacobian sparsity).
//
// ModelArrays is built from an mjModel (throwing ModelError for anything the engine does not
// implement) and holds every array in double. pack<T>() lays them out in one contiguous block of
// T and int arrays; Model<T> is a view of such a block by pointers, so the same struct describes
// the host copy and the device copy (one cudaMemcpy of the block, then rebase the view).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/gpu/hd.h"

struct mjModel_;
typedef struct mjModel_ mjModel;

namespace bidex::sim::gpu {

// Sizes of one world (the counts that array lengths are written in).
struct Sizes {
  int nq = 0, nv = 0, nu = 0, nbody = 0, njnt = 0, ngeom = 0, nsite = 0, ntendon = 0;
  int nM = 0;         // entries of the mass matrix in MuJoCo's sparse tree layout (dof_Madr)
  int nlevel = 0;     // depth of the body tree + 1 (the world is level 0)
  int ndlevel = 0;    // depth of the dof tree + 1
  int ntree = 0;      // kinematic trees (contiguous dof ranges that share no rows of M)
  int maxtreedofs = 0;  // dofs of the largest tree
  int ntennz = 0;     // nonzeros of all fixed-tendon Jacobians
  int nactnnz = 0;    // nonzeros of all actuator moment rows
  int ncand = 0;      // constraint candidates (rows that can become active)
  int ncandnnz = 0;   // nonzeros of all candidate Jacobian rows
  int nhent = 0;      // mass-matrix entries that constraint rows add to (Newton Hessian)
  int nhcon = 0;      // (entry, row) contributions to them
  int ndofcand = 0;   // (dof, row nonzero) pairs, for J' f by dof
  int nsubtree = 0;   // (dof, body whose Jacobian chain holds the dof) pairs, for xfrc_applied
};

// MuJoCo 2.2.2 enum values the stage functions need (checked against mujoco.h in model.cc).
enum JointType : int { kJointFree = 0, kJointBall = 1, kJointSlide = 2, kJointHinge = 3 };
enum RowState : int {
  kStateSatisfied = 0,
  kStateQuadratic = 1,
  kStateLinearNeg = 2,
  kStateLinearPos = 3,
};
enum DisableBit : int {
  kDisablePassive = 1 << 5,
  kDisableGravity = 1 << 6,
  kDisableClampCtrl = 1 << 7,
  kDisableActuation = 1 << 10,
};
enum ActuatorType : int { kGainFixed = 0, kGainAffine = 1, kBiasNone = 0, kBiasAffine = 1 };

// Kinds of constraint candidates, in MuJoCo's row order: equalities, dof and tendon friction,
// joint limits (lower side first), ball limits, tendon limits.
enum CandKind : int {
  kCandEqJoint = 0,
  kCandEqTendon = 1,
  kCandFrictionDof = 2,
  kCandFrictionTendon = 3,
  kCandLimitLow = 4,   // hinge or slide joint, lower side
  kCandLimitHigh = 5,  // hinge or slide joint, upper side
  kCandLimitBall = 6,
  kCandTendonLow = 7,
  kCandTendonHigh = 8,
};

// Real-valued model arrays: name, length (in Sizes `s`), meaning. Copied from mjModel unless
// marked "derived".
#define BIDEX_GPU_MODEL_REALS(X)                                                               \
  X(body_pos, s.nbody * 3, "offset from the parent body")                                      \
  X(body_quat, s.nbody * 4, "orientation relative to the parent body")                         \
  X(body_ipos, s.nbody * 3, "centre of mass in the body frame")                                \
  X(body_iquat, s.nbody * 4, "principal inertia frame in the body frame")                      \
  X(body_mass, s.nbody, "mass")                                                                \
  X(body_inertia, s.nbody * 3, "principal inertia")                                            \
  X(body_subtreemass, s.nbody, "derived: mass of the subtree, summed in MuJoCo's order")       \
  X(jnt_pos, s.njnt * 3, "anchor in the body frame")                                           \
  X(jnt_axis, s.njnt * 3, "axis in the body frame")                                            \
  X(jnt_stiffness, s.njnt, "spring stiffness")                                                 \
  X(qpos0, s.nq, "reference configuration")                                                    \
  X(qpos_spring, s.nq, "spring rest configuration")                                            \
  X(dof_armature, s.nv, "armature inertia")                                                    \
  X(dof_damping, s.nv, "viscous damping")                                                      \
  X(dof_M0, s.nv, "diagonal of M for dofs of simple bodies")                                   \
  X(geom_pos, s.ngeom * 3, "offset in the body frame")                                         \
  X(geom_quat, s.ngeom * 4, "orientation in the body frame")                                   \
  X(site_pos, s.nsite * 3, "offset in the body frame")                                         \
  X(site_quat, s.nsite * 4, "orientation in the body frame")                                   \
  X(tendon_stiffness, s.ntendon, "spring stiffness")                                           \
  X(tendon_damping, s.ntendon, "damping")                                                      \
  X(tendon_lengthspring, s.ntendon, "spring rest length")                                      \
  X(ten_coef, s.ntennz, "fixed tendon: coefficient of each joint (its Jacobian entry)")        \
  X(actuator_gainprm, s.nu * 3, "gain parameters (fixed: [0]; affine: [0] + [1] l + [2] v)")   \
  X(actuator_biasprm, s.nu * 3, "bias parameters (affine: [0] + [1] l + [2] v)")               \
  X(actuator_ctrlrange, s.nu * 2, "control range (when ctrllimited)")                          \
  X(actuator_forcerange, s.nu * 2, "force range (when forcelimited)")                          \
  X(actuator_gear, s.nu, "gear[0]")                                                            \
  X(act_moment, s.nactnnz, "derived: actuator moment entries (constant for joint and fixed "   \
                           "tendon transmissions)")                                            \
  X(cand_K, s.ncand, "derived: reference stiffness from solref/solimp (0 for friction)")       \
  X(cand_B, s.ncand, "derived: reference damping from solref/solimp")                          \
  X(cand_solimp, s.ncand * 5, "derived: impedance parameters, clamped as MuJoCo does")         \
  X(cand_diag, s.ncand, "derived: MuJoCo's diagonal approximation of A (mj_diagApprox)")       \
  X(cand_margin, s.ncand, "derived: margin of limit rows")                                     \
  X(cand_floss, s.ncand, "derived: friction loss of friction rows")                            \
  X(cand_prm, s.ncand * 5, "derived: equality polynomial (eq rows) or range bound (limits)")   \
  X(cand_ref, s.ncand * 2, "derived: reference positions of the two coupled objects (eq rows)") \
  X(cand_c1, s.ncandnnz, "derived: Jacobian entry (eq rows: of object 1)")                     \
  X(cand_c2, s.ncandnnz, "derived: eq rows: Jacobian entry of object 2 (times -deriv when used)")

// Integer model arrays.
#define BIDEX_GPU_MODEL_INTS(X)                                                                \
  X(body_parentid, s.nbody, "parent body")                                                     \
  X(body_rootid, s.nbody, "root of the body's tree")                                           \
  X(body_jntnum, s.nbody, "joints of the body")                                                \
  X(body_jntadr, s.nbody, "first joint of the body")                                           \
  X(body_dofnum, s.nbody, "dofs of the body")                                                  \
  X(body_dofadr, s.nbody, "first dof of the body")                                             \
  X(body_sameframe, s.nbody, "inertial frame equals body frame")                               \
  X(body_chaindof, s.nbody, "derived: last dof of the body or of its nearest moving ancestor " \
                            "(-1: none), where Jacobian chains start")                          \
  X(level_adr, s.nlevel + 1, "derived: start of each tree level in level_body")               \
  X(level_body, s.nbody, "derived: bodies by tree level, the world first")                     \
  X(child_adr, s.nbody + 1, "derived: start of each body's children in child_body")           \
  X(child_body, s.nbody, "derived: children, highest id first (MuJoCo's summation order)")     \
  X(jnt_type, s.njnt, "mjtJoint")                                                              \
  X(jnt_qposadr, s.njnt, "first qpos")                                                         \
  X(jnt_dofadr, s.njnt, "first dof")                                                           \
  X(jnt_bodyid, s.njnt, "body")                                                                \
  X(dof_bodyid, s.nv, "body")                                                                  \
  X(dof_jntid, s.nv, "joint")                                                                  \
  X(dof_parentid, s.nv, "parent dof (-1: root)")                                               \
  X(dof_Madr, s.nv + 1, "first entry of the dof's row in qM (the diagonal); [nv] = nM")       \
  X(dof_simplenum, s.nv, "dofs of a simple body (M diagonal, constant)")                       \
  X(M_col, s.nM, "derived: column dof of each qM entry (the row's dof or an ancestor)")        \
  X(tree_dofadr, s.ntree + 1, "derived: first dof of each kinematic tree; [ntree] = nv")      \
  X(dlevel_adr, s.ndlevel + 1, "derived: start of each dof-tree level in dlevel_dof")         \
  X(dlevel_dof, s.nv, "derived: dofs by depth (number of ancestor dofs), roots first")         \
  X(M_row, s.nM, "derived: row dof of each qM entry")                                         \
  X(M_coladr, s.nv + 1, "derived: start of each dof's below-diagonal column in M_colent")      \
  X(M_colent, s.nM - s.nv, "derived: qM entries of each column below the diagonal, last row "  \
                           "first")                                                            \
  X(dof_subtreeadr, s.nv + 1, "derived: start of each dof's bodies in dof_subtreebody")     \
  X(dof_subtreebody, s.nsubtree, "derived: bodies moved by the dof (its body's subtree), "     \
                                 "increasing")                                                 \
  X(geom_bodyid, s.ngeom, "body")                                                              \
  X(geom_sameframe, s.ngeom, "0: own frame, 1: body frame, 2: inertial frame")                 \
  X(site_bodyid, s.nsite, "body")                                                              \
  X(site_sameframe, s.nsite, "0: own frame, 1: body frame, 2: inertial frame")                 \
  X(ten_adr, s.ntendon + 1, "derived: first entry of each fixed tendon in ten_coef")           \
  X(ten_dof, s.ntennz, "derived: dof of each tendon entry")                                    \
  X(ten_qpos, s.ntennz, "derived: qpos of each tendon entry")                                  \
  X(actuator_gaintype, s.nu, "mjtGain (fixed or affine)")                                      \
  X(actuator_biastype, s.nu, "mjtBias (none or affine)")                                       \
  X(actuator_ctrllimited, s.nu, "clamp ctrl to ctrlrange")                                     \
  X(actuator_forcelimited, s.nu, "clamp force to forcerange")                                  \
  X(act_trn, s.nu, "derived: 0 joint transmission (qpos act_obj), 1 tendon (tendon act_obj)")  \
  X(act_obj, s.nu, "derived: qpos address or tendon id of the transmission")                   \
  X(act_adr, s.nu + 1, "derived: first moment entry of each actuator")                         \
  X(act_dof, s.nactnnz, "derived: dof of each moment entry")                                 \
  X(act_of, s.nactnnz, "derived: actuator of each moment entry")                                   \
  X(dof_actadr, s.nv + 1, "derived: start of each dof's moment entries in dof_actent")        \
  X(dof_actent, s.nactnnz, "derived: moment entries by dof (indexes into act_moment)")         \
  X(cand_kind, s.ncand, "derived: CandKind")                                                   \
  X(cand_type, s.ncand, "derived: MuJoCo's mjtConstraint of the row (efc_type)")               \
  X(cand_id, s.ncand, "derived: MuJoCo's efc_id of the row")                                   \
  X(cand_obj, s.ncand * 2, "derived: joint or tendon ids the row reads (-1: none)")            \
  X(cand_adr, s.ncand + 1, "derived: first Jacobian nonzero of each candidate")                \
  X(cand_dof, s.ncandnnz, "derived: dof of each Jacobian nonzero, increasing within a row")    \
  X(nnz_cand, s.ncandnnz, "derived: candidate of each Jacobian nonzero")                       \
  X(dof_candadr, s.nv + 1, "derived: start of each dof's Jacobian nonzeros in dof_candent")   \
  X(dof_candent, s.ndofcand, "derived: Jacobian nonzeros by dof (indexes into cand_dof)")      \
  X(hent_addr, s.nhent, "derived: qM addresses that constraint rows add to")                   \
  X(hent_adr, s.nhent + 1, "derived: start of each address's contributions")                  \
  X(hcon_a, s.nhcon, "derived: contribution D J[a] J[b]: nonzero a (row dof)")                 \
  X(hcon_b, s.nhcon, "derived: contribution D J[a] J[b]: nonzero b (column dof)")

// Options that every stage reads.
template <class T>
struct ModelOptions {
  T timestep = 0;
  T gravity[3] = {0, 0, 0};
  T meaninertia = 1;      // MuJoCo's stat.meaninertia: scales the solver's stopping tests
  T tolerance = 0;        // solver tolerance (the larger of MuJoCo's and the precision floor)
  int iterations = 0;     // solver iteration cap
  int disableflags = 0;   // MuJoCo's mjtDisableBit set (gravity, passive, clampctrl, ...)
  int warmstart = 1;      // start the solver from the cheaper of qacc_warmstart and qacc_smooth
  int implicit_damping = 0;  // Euler treats dof damping implicitly (some dof_damping > 0)
};

// A view of one packed model: sizes, options and one pointer per array.
template <class T>
struct Model {
  Sizes s;
  ModelOptions<T> opt;
#define BIDEX_X(name, count, doc) const T* name = nullptr;
  BIDEX_GPU_MODEL_REALS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc) const int* name = nullptr;
  BIDEX_GPU_MODEL_INTS(BIDEX_X)
#undef BIDEX_X
};

// Choices that are not in the mjModel.
struct EngineOptions {
  // Part 1 of the engine has no collision stage: a model with contacts enabled is refused
  // unless this is set (contacts are then silently absent).
  bool ignore_contacts = false;
  // Smallest solver tolerance in float32 (MuJoCo's 1e-8 is below float resolution); float64
  // uses the model's tolerance as is.
  double float_tolerance_floor = 1e-6;
};

// The model arrays in double, built from an mjModel.
class ModelArrays {
 public:
  // Throws ModelError naming the first feature the engine does not implement.
  explicit ModelArrays(const mjModel* m, EngineOptions options = {});

  Sizes s;
  ModelOptions<double> opt;
#define BIDEX_X(name, count, doc) std::vector<double> name;
  BIDEX_GPU_MODEL_REALS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc) std::vector<int> name;
  BIDEX_GPU_MODEL_INTS(BIDEX_X)
#undef BIDEX_X
  EngineOptions options;
};

// One contiguous block holding a model's arrays in precision T (reals) and int.
template <class T>
class PackedModel {
 public:
  explicit PackedModel(const ModelArrays& a);

  const std::vector<std::byte>& bytes() const { return bytes_; }
  // A view whose pointers point into the block starting at `base` (the host copy below or a
  // device copy of bytes()).
  Model<T> view(const std::byte* base) const;
  Model<T> host_view() const { return view(bytes_.data()); }

 private:
  Sizes s_;
  ModelOptions<T> opt_;
  std::vector<std::byte> bytes_;
  std::vector<size_t> offsets_;  // one per array, reals then ints, in table order
};

}  // namespace bidex::sim::gpu
