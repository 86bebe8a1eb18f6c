#include "sim/gpu/model.h"

#include <algorithm>
#include <cstring>
#include <map>
#include <utility>

#include <mujoco/mujoco.h>

#include "core/error.h"

namespace bidex::sim::gpu {

static_assert(int(kJointFree) == int(mjJNT_FREE) && int(kJointBall) == int(mjJNT_BALL) &&
              int(kJointSlide) == int(mjJNT_SLIDE) && int(kJointHinge) == int(mjJNT_HINGE));
static_assert(int(kStateSatisfied) == int(mjCNSTRSTATE_SATISFIED) &&
              int(kStateQuadratic) == int(mjCNSTRSTATE_QUADRATIC) &&
              int(kStateLinearNeg) == int(mjCNSTRSTATE_LINEARNEG) &&
              int(kStateLinearPos) == int(mjCNSTRSTATE_LINEARPOS));
static_assert(int(kDisablePassive) == int(mjDSBL_PASSIVE) &&
              int(kDisableGravity) == int(mjDSBL_GRAVITY) &&
              int(kDisableClampCtrl) == int(mjDSBL_CLAMPCTRL) &&
              int(kDisableActuation) == int(mjDSBL_ACTUATION));
static_assert(int(kGainFixed) == int(mjGAIN_FIXED) && int(kGainAffine) == int(mjGAIN_AFFINE) &&
              int(kBiasNone) == int(mjBIAS_NONE) && int(kBiasAffine) == int(mjBIAS_AFFINE));

namespace {

[[noreturn]] void unsupported(const std::string& what) {
  throw ModelError("GPU engine: " + what);
}

std::string name_of(const mjModel* m, int type, int id) {
  const char* n = mj_id2name(m, type, id);
  std::string out = n && *n ? "'" : "#";
  out += n && *n ? std::string(n) + "'" : std::to_string(id);
  return out;
}

template <class Src>
std::vector<double> reals(const Src* p, int n) {
  return std::vector<double>(p, p + n);
}
template <class Src>
std::vector<int> ints(const Src* p, int n) {
  return std::vector<int>(p, p + n);
}

// Groups items 0..n-1 by their key in [0, nkey), keeping their order: the items of key k are
// ent[adr[k]] .. ent[adr[k + 1] - 1].
void group_by(const std::vector<int>& key, int nkey, std::vector<int>& adr,
              std::vector<int>& ent) {
  adr.assign(nkey + 1, 0);
  for (int k : key) adr[k + 1]++;
  for (int k = 0; k < nkey; ++k) adr[k + 1] += adr[k];
  ent.assign(key.size(), -1);
  std::vector<int> fill(adr.begin(), adr.end() - 1);
  for (size_t i = 0; i < key.size(); ++i) ent[fill[key[i]]++] = static_cast<int>(i);
}

bool disabled(const mjModel* m, int flag) { return (m->opt.disableflags & flag) != 0; }

// true when dof `a` is dof `b` or one of its ancestors
bool is_ancestor_or_self(const mjModel* m, int a, int b) {
  for (int j = b; j >= 0; j = m->dof_parentid[j])
    if (j == a) return true;
  return false;
}

// position of ancestor-or-self `anc` in the qM row of dof `i` (0 = diagonal)
int chain_offset(const mjModel* m, int i, int anc) {
  int k = 0;
  for (int j = i; j >= 0; j = m->dof_parentid[j], ++k)
    if (j == anc) return k;
  return -1;
}

// MuJoCo 2.2.2's processing of a constraint's solref/solimp (mixed format replaced by the
// defaults, REFSAFE, clamped impedance), then the row's reference stiffness and damping.
void solver_params(const mjModel* m, const double* solref_in, const double* solimp_in,
                   bool friction, double* K, double* B, double* solimp) {
  double solref[2] = {solref_in[0], solref_in[1]};
  for (int k = 0; k < 5; ++k) solimp[k] = solimp_in[k];
  if ((solref[0] > 0) != (solref[1] > 0)) {
    solref[0] = 0.02;
    solref[1] = 1;
    const double def[5] = {0.9, 0.95, 0.001, 0.5, 2};
    for (int k = 0; k < 5; ++k) solimp[k] = def[k];
  }
  if (!disabled(m, mjDSBL_REFSAFE) && solref[0] > 0)
    solref[0] = std::max(solref[0], 2 * m->opt.timestep);
  solimp[0] = std::min(kMaxImp, std::max(kMinImp, solimp[0]));
  solimp[1] = std::min(kMaxImp, std::max(kMinImp, solimp[1]));
  solimp[2] = std::max(0.0, solimp[2]);
  solimp[3] = std::min(kMaxImp, std::max(kMinImp, solimp[3]));
  solimp[4] = std::max(1.0, solimp[4]);
  const double dmax = solimp[1];
  if (friction)
    *K = 0;
  else if (solref[0] > 0)
    *K = 1 / std::max(kMinVal, dmax * dmax * solref[0] * solref[0] * solref[1] * solref[1]);
  else
    *K = -solref[0] / std::max(kMinVal, dmax * dmax);
  if (solref[1] > 0)
    *B = 2 / std::max(kMinVal, dmax * solref[0]);
  else
    *B = -solref[1] / std::max(kMinVal, dmax);
}

// one constraint candidate while the tables are built
struct Cand {
  int kind = 0, type = 0, id = 0, obj[2] = {-1, -1};
  double K = 0, B = 0, solimp[5] = {0, 0, 0, 0, 0}, diag = 0, margin = 0, floss = 0;
  double prm[5] = {0, 0, 0, 0, 0}, ref[2] = {0, 0};
  std::vector<int> dof;            // increasing
  std::vector<double> c1, c2;      // per dof
  void add(int d, double a, double b) {
    auto it = std::lower_bound(dof.begin(), dof.end(), d);
    size_t k = it - dof.begin();
    if (it != dof.end() && *it == d) {
      c1[k] += a;
      c2[k] += b;
    } else {
      dof.insert(it, d);
      c1.insert(c1.begin() + k, a);
      c2.insert(c2.begin() + k, b);
    }
  }
};

}  // namespace

ModelArrays::ModelArrays(const mjModel* m, EngineOptions options_in) : options(options_in) {
  // what part 1 of the engine implements
  if (m->opt.integrator != mjINT_EULER)
    unsupported("only the Euler integrator is implemented, the model asks for integrator " +
                std::to_string(m->opt.integrator));
  if (m->opt.density > 0 || m->opt.viscosity > 0)
    unsupported("fluid forces (density/viscosity > 0) are not implemented");
  if (m->nmocap > 0) unsupported("mocap bodies are not implemented");
  if (m->na > 0) unsupported("actuator activation dynamics (na > 0) are not implemented");
  if (m->opt.noslip_iterations > 0) unsupported("the noslip solver is not implemented");
  if (!disabled(m, mjDSBL_CONTACT) && !options.ignore_contacts) {
    bool collides = m->npair > 0;
    for (int g = 0; g < m->ngeom && !collides; ++g)
      collides = m->geom_contype[g] != 0 || m->geom_conaffinity[g] != 0;
    if (collides)
      unsupported("contacts are not implemented yet (collision is part 2): expected a model "
                  "with mjDSBL_CONTACT set or EngineOptions::ignore_contacts, got a model whose "
                  "geoms can collide");
  }
  for (int b = 1; b < m->nbody; ++b)
    for (int j = 0; j < m->body_jntnum[b]; ++j)
      if (m->jnt_type[m->body_jntadr[b] + j] == mjJNT_FREE && m->body_jntnum[b] != 1)
        unsupported("body " + name_of(m, mjOBJ_BODY, b) + " has a free joint among others");

  // sizes
  s.nq = m->nq;
  s.nv = m->nv;
  s.nu = m->nu;
  s.nbody = m->nbody;
  s.njnt = m->njnt;
  s.ngeom = m->ngeom;
  s.nsite = m->nsite;
  s.ntendon = m->ntendon;
  s.nM = m->nM;

  // options
  opt.timestep = m->opt.timestep;
  for (int k = 0; k < 3; ++k) opt.gravity[k] = m->opt.gravity[k];
  opt.meaninertia = m->stat.meaninertia;
  opt.tolerance = m->opt.tolerance;
  opt.iterations = m->opt.iterations;
  opt.disableflags = m->opt.disableflags;
  opt.warmstart = !disabled(m, mjDSBL_WARMSTART);
  opt.implicit_damping = 0;
  for (int i = 0; i < m->nv; ++i)
    if (m->dof_damping[i] > 0) opt.implicit_damping = 1;

  // bodies
  body_pos = reals(m->body_pos, 3 * m->nbody);
  body_quat = reals(m->body_quat, 4 * m->nbody);
  body_ipos = reals(m->body_ipos, 3 * m->nbody);
  body_iquat = reals(m->body_iquat, 4 * m->nbody);
  body_mass = reals(m->body_mass, m->nbody);
  body_inertia = reals(m->body_inertia, 3 * m->nbody);
  body_parentid = ints(m->body_parentid, m->nbody);
  body_rootid = ints(m->body_rootid, m->nbody);
  body_jntnum = ints(m->body_jntnum, m->nbody);
  body_jntadr = ints(m->body_jntadr, m->nbody);
  body_dofnum = ints(m->body_dofnum, m->nbody);
  body_dofadr = ints(m->body_dofadr, m->nbody);
  body_sameframe = ints(m->body_sameframe, m->nbody);

  // subtree masses, accumulated leaves first as mj_comPos does
  body_subtreemass.assign(m->nbody, 0.0);
  for (int b = m->nbody - 1; b >= 0; --b) {
    body_subtreemass[b] += m->body_mass[b];
    if (b) body_subtreemass[m->body_parentid[b]] += body_subtreemass[b];
  }

  // where each body's Jacobian chain starts: its last dof or its nearest moving ancestor's
  body_chaindof.assign(m->nbody, -1);
  for (int b = 0; b < m->nbody; ++b) {
    int a = b;
    while (a > 0 && m->body_dofnum[a] == 0) a = m->body_parentid[a];
    body_chaindof[b] = a > 0 ? m->body_dofadr[a] + m->body_dofnum[a] - 1 : -1;
  }

  // tree levels (a parent always has a lower id, so one pass gives every depth)
  std::vector<int> depth(m->nbody, 0);
  for (int b = 1; b < m->nbody; ++b) depth[b] = depth[m->body_parentid[b]] + 1;
  s.nlevel = 1 + *std::max_element(depth.begin(), depth.end());
  group_by(depth, s.nlevel, level_adr, level_body);

  // children, highest id first
  child_adr.assign(m->nbody + 1, 0);
  for (int b = 1; b < m->nbody; ++b) child_adr[m->body_parentid[b] + 1]++;
  for (int b = 0; b < m->nbody; ++b) child_adr[b + 1] += child_adr[b];
  child_body.assign(m->nbody, -1);
  {
    std::vector<int> fill(child_adr.begin(), child_adr.end() - 1);
    for (int b = m->nbody - 1; b >= 1; --b) child_body[fill[m->body_parentid[b]]++] = b;
  }

  // joints
  jnt_pos = reals(m->jnt_pos, 3 * m->njnt);
  jnt_axis = reals(m->jnt_axis, 3 * m->njnt);
  jnt_stiffness = reals(m->jnt_stiffness, m->njnt);
  jnt_type = ints(m->jnt_type, m->njnt);
  jnt_qposadr = ints(m->jnt_qposadr, m->njnt);
  jnt_dofadr = ints(m->jnt_dofadr, m->njnt);
  jnt_bodyid = ints(m->jnt_bodyid, m->njnt);
  qpos0 = reals(m->qpos0, m->nq);
  qpos_spring = reals(m->qpos_spring, m->nq);

  // dofs and the mass matrix layout
  dof_armature = reals(m->dof_armature, m->nv);
  dof_damping = reals(m->dof_damping, m->nv);
  dof_M0 = reals(m->dof_M0, m->nv);
  dof_bodyid = ints(m->dof_bodyid, m->nv);
  dof_jntid = ints(m->dof_jntid, m->nv);
  dof_parentid = ints(m->dof_parentid, m->nv);
  dof_simplenum = ints(m->dof_simplenum, m->nv);
  dof_Madr = ints(m->dof_Madr, m->nv);
  dof_Madr.push_back(m->nM);
  M_col.assign(m->nM, -1);
  M_row.assign(m->nM, -1);
  for (int i = 0; i < m->nv; ++i) {
    int e = m->dof_Madr[i];
    for (int j = i; j >= 0; j = m->dof_parentid[j]) {
      M_row[e] = i;
      M_col[e++] = j;
    }
    if (e != dof_Madr[i + 1])
      unsupported("unexpected mass matrix layout at dof " + std::to_string(i));
  }
  // kinematic trees: a root dof (no parent) starts one, and every dof up to the next root must
  // descend from it; otherwise all dofs count as one tree (factor_ld then runs in plain order)
  {
    tree_dofadr.clear();
    bool contiguous = true;
    int root = -1;
    for (int i = 0; i < m->nv; ++i) {
      if (m->dof_parentid[i] < 0) {
        tree_dofadr.push_back(i);
        root = i;
      } else if (!is_ancestor_or_self(m, root, i)) {
        contiguous = false;
      }
    }
    if (!contiguous) tree_dofadr.assign(m->nv ? 1 : 0, 0);
    tree_dofadr.push_back(m->nv);
    s.ntree = static_cast<int>(tree_dofadr.size()) - 1;
    s.maxtreedofs = 0;
    for (int t = 0; t < s.ntree; ++t)
      s.maxtreedofs = std::max(s.maxtreedofs, tree_dofadr[t + 1] - tree_dofadr[t]);
  }

  // dofs by depth in the dof tree (the length of their qM row - 1)
  {
    std::vector<int> ddepth(m->nv);
    int maxd = 0;
    for (int i = 0; i < m->nv; ++i) {
      ddepth[i] = dof_Madr[i + 1] - dof_Madr[i] - 1;
      maxd = std::max(maxd, ddepth[i]);
    }
    s.ndlevel = m->nv ? maxd + 1 : 0;
    group_by(ddepth, s.ndlevel, dlevel_adr, dlevel_dof);
  }
  M_coladr.assign(m->nv + 1, 0);
  for (int e = 0; e < m->nM; ++e)
    if (M_col[e] != -1) M_coladr[M_col[e] + 1]++;
  for (int i = 0; i < m->nv; ++i) M_coladr[i + 1]--;  // not the diagonal
  for (int i = 0; i < m->nv; ++i) M_coladr[i + 1] += M_coladr[i];
  M_colent.assign(m->nM - m->nv, -1);
  {
    std::vector<int> fill(M_coladr.begin(), M_coladr.end() - 1);
    for (int i = m->nv - 1; i >= 0; --i)
      for (int e = dof_Madr[i] + 1; e < dof_Madr[i + 1]; ++e) M_colent[fill[M_col[e]]++] = e;
  }

  // bodies moved by each dof: those whose nearest moving ancestor-or-self lies under the dof's body
  dof_subtreeadr.assign(1, 0);
  for (int i = 0; i < m->nv; ++i) {
    const int top = m->dof_bodyid[i];
    for (int b = 1; b < m->nbody; ++b) {
      int a = b;
      while (a > 0 && a != top) a = m->body_parentid[a];
      if (a == top) dof_subtreebody.push_back(b);
    }
    dof_subtreeadr.push_back(static_cast<int>(dof_subtreebody.size()));
  }
  s.nsubtree = static_cast<int>(dof_subtreebody.size());

  // geoms and sites
  geom_pos = reals(m->geom_pos, 3 * m->ngeom);
  geom_quat = reals(m->geom_quat, 4 * m->ngeom);
  geom_bodyid = ints(m->geom_bodyid, m->ngeom);
  geom_sameframe = ints(m->geom_sameframe, m->ngeom);
  site_pos = reals(m->site_pos, 3 * m->nsite);
  site_quat = reals(m->site_quat, 4 * m->nsite);
  site_bodyid = ints(m->site_bodyid, m->nsite);
  site_sameframe = ints(m->site_sameframe, m->nsite);

  // fixed tendons
  tendon_stiffness = reals(m->tendon_stiffness, m->ntendon);
  tendon_damping = reals(m->tendon_damping, m->ntendon);
  tendon_lengthspring = reals(m->tendon_lengthspring, m->ntendon);
  ten_adr.assign(1, 0);
  for (int t = 0; t < m->ntendon; ++t) {
    const int adr = m->tendon_adr[t];
    for (int k = 0; k < m->tendon_num[t]; ++k) {
      if (m->wrap_type[adr + k] != mjWRAP_JOINT)
        unsupported("tendon " + name_of(m, mjOBJ_TENDON, t) +
                    " is spatial; only fixed (joint) tendons are implemented");
      const int j = m->wrap_objid[adr + k];
      if (m->jnt_type[j] != mjJNT_HINGE && m->jnt_type[j] != mjJNT_SLIDE)
        unsupported("tendon " + name_of(m, mjOBJ_TENDON, t) +
                    " uses a joint that is not hinge or slide");
      ten_coef.push_back(m->wrap_prm[adr + k]);
      ten_dof.push_back(m->jnt_dofadr[j]);
      ten_qpos.push_back(m->jnt_qposadr[j]);
    }
    ten_adr.push_back(static_cast<int>(ten_coef.size()));
  }
  s.ntennz = static_cast<int>(ten_coef.size());

  // actuators: joint (hinge/slide) and fixed-tendon transmissions, no activation dynamics
  actuator_gainprm.assign(3 * m->nu, 0.0);
  actuator_biasprm.assign(3 * m->nu, 0.0);
  actuator_ctrlrange = reals(m->actuator_ctrlrange, 2 * m->nu);
  actuator_forcerange = reals(m->actuator_forcerange, 2 * m->nu);
  actuator_gear.assign(m->nu, 0.0);
  actuator_gaintype = ints(m->actuator_gaintype, m->nu);
  actuator_biastype = ints(m->actuator_biastype, m->nu);
  actuator_ctrllimited = ints(m->actuator_ctrllimited, m->nu);
  actuator_forcelimited = ints(m->actuator_forcelimited, m->nu);
  act_trn.assign(m->nu, 0);
  act_obj.assign(m->nu, -1);
  act_adr.assign(1, 0);
  for (int a = 0; a < m->nu; ++a) {
    const std::string who = "actuator " + name_of(m, mjOBJ_ACTUATOR, a);
    if (m->actuator_dyntype[a] != mjDYN_NONE) unsupported(who + " has activation dynamics");
    if (m->actuator_gaintype[a] != mjGAIN_FIXED && m->actuator_gaintype[a] != mjGAIN_AFFINE)
      unsupported(who + ": only fixed and affine gains are implemented");
    if (m->actuator_biastype[a] != mjBIAS_NONE && m->actuator_biastype[a] != mjBIAS_AFFINE)
      unsupported(who + ": only no bias or affine bias is implemented");
    for (int k = 0; k < 3; ++k) {
      actuator_gainprm[3 * a + k] = m->actuator_gainprm[mjNGAIN * a + k];
      actuator_biasprm[3 * a + k] = m->actuator_biasprm[mjNBIAS * a + k];
    }
    const double gear = m->actuator_gear[6 * a];
    actuator_gear[a] = gear;
    const int id = m->actuator_trnid[2 * a];
    if (m->actuator_trntype[a] == mjTRN_JOINT) {
      if (m->jnt_type[id] != mjJNT_HINGE && m->jnt_type[id] != mjJNT_SLIDE)
        unsupported(who + " drives a ball or free joint; only hinge and slide are implemented");
      act_trn[a] = 0;
      act_obj[a] = m->jnt_qposadr[id];
      act_dof.push_back(m->jnt_dofadr[id]);
      act_of.push_back(a);
      act_moment.push_back(gear);
    } else if (m->actuator_trntype[a] == mjTRN_TENDON) {
      act_trn[a] = 1;
      act_obj[a] = id;
      for (int k = ten_adr[id]; k < ten_adr[id + 1]; ++k) {
        act_dof.push_back(ten_dof[k]);
        act_of.push_back(a);
        act_moment.push_back(ten_coef[k] * gear);
      }
    } else {
      unsupported(who + ": only joint and tendon transmissions are implemented");
    }
    act_adr.push_back(static_cast<int>(act_dof.size()));
  }
  s.nactnnz = static_cast<int>(act_dof.size());
  group_by(act_dof, m->nv, dof_actadr, dof_actent);

  // constraint candidates, in MuJoCo's row order
  std::vector<Cand> cands;
  const bool constraints = !disabled(m, mjDSBL_CONSTRAINT) && m->njmax > 0;
  if (constraints && !disabled(m, mjDSBL_EQUALITY)) {
    for (int i = 0; i < m->neq; ++i) {
      if (!m->eq_active[i]) continue;
      const std::string who = "equality " + name_of(m, mjOBJ_EQUALITY, i);
      if (m->eq_type[i] != mjEQ_JOINT && m->eq_type[i] != mjEQ_TENDON)
        unsupported(who + ": only joint and tendon equalities are implemented");
      Cand c;
      c.type = mjCNSTR_EQUALITY;
      c.id = i;
      c.obj[0] = m->eq_obj1id[i];
      c.obj[1] = m->eq_obj2id[i];
      for (int k = 0; k < 5; ++k) c.prm[k] = m->eq_data[mjNEQDATA * i + k];
      if (m->eq_type[i] == mjEQ_JOINT) {
        c.kind = kCandEqJoint;
        for (int j = 0; j < 2; ++j) {
          const int jnt = c.obj[j];
          if (jnt < 0) continue;
          if (m->jnt_type[jnt] != mjJNT_HINGE && m->jnt_type[jnt] != mjJNT_SLIDE)
            unsupported(who + " couples a joint that is not hinge or slide");
          c.ref[j] = m->qpos0[m->jnt_qposadr[jnt]];
          c.add(m->jnt_dofadr[jnt], j == 0 ? 1.0 : 0.0, j == 1 ? 1.0 : 0.0);
          c.diag += m->dof_invweight0[m->jnt_dofadr[jnt]];
        }
      } else {
        c.kind = kCandEqTendon;
        for (int j = 0; j < 2; ++j) {
          const int t = c.obj[j];
          if (t < 0) continue;
          c.ref[j] = m->tendon_length0[t];
          for (int k = ten_adr[t]; k < ten_adr[t + 1]; ++k)
            c.add(ten_dof[k], j == 0 ? ten_coef[k] : 0.0, j == 1 ? ten_coef[k] : 0.0);
          c.diag += m->tendon_invweight0[t];
        }
      }
      solver_params(m, m->eq_solref + 2 * i, m->eq_solimp + 5 * i, false, &c.K, &c.B, c.solimp);
      cands.push_back(c);
    }
  }
  if (constraints && !disabled(m, mjDSBL_FRICTIONLOSS)) {
    for (int i = 0; i < m->nv; ++i) {
      if (!(m->dof_frictionloss[i] > 0)) continue;
      Cand c;
      c.kind = kCandFrictionDof;
      c.type = mjCNSTR_FRICTION_DOF;
      c.id = i;
      c.floss = m->dof_frictionloss[i];
      c.diag = m->dof_invweight0[i];
      c.add(i, 1, 0);
      solver_params(m, m->dof_solref + 2 * i, m->dof_solimp + 5 * i, true, &c.K, &c.B, c.solimp);
      cands.push_back(c);
    }
    for (int t = 0; t < m->ntendon; ++t) {
      if (!(m->tendon_frictionloss[t] > 0)) continue;
      Cand c;
      c.kind = kCandFrictionTendon;
      c.type = mjCNSTR_FRICTION_TENDON;
      c.id = t;
      c.obj[0] = t;
      c.floss = m->tendon_frictionloss[t];
      c.diag = m->tendon_invweight0[t];
      for (int k = ten_adr[t]; k < ten_adr[t + 1]; ++k) c.add(ten_dof[k], ten_coef[k], 0);
      solver_params(m, m->tendon_solref_fri + 2 * t, m->tendon_solimp_fri + 5 * t, true, &c.K,
                    &c.B, c.solimp);
      cands.push_back(c);
    }
  }
  if (constraints && !disabled(m, mjDSBL_LIMIT)) {
    for (int j = 0; j < m->njnt; ++j) {
      if (!m->jnt_limited[j]) continue;
      const int type = m->jnt_type[j], dof = m->jnt_dofadr[j];
      Cand c;
      c.type = mjCNSTR_LIMIT_JOINT;
      c.id = j;
      c.obj[0] = j;
      c.margin = m->jnt_margin[j];
      c.diag = m->dof_invweight0[dof];
      solver_params(m, m->jnt_solref + 2 * j, m->jnt_solimp + 5 * j, false, &c.K, &c.B, c.solimp);
      if (type == mjJNT_SLIDE || type == mjJNT_HINGE) {
        for (int side = -1; side <= 1; side += 2) {
          Cand cs = c;
          cs.kind = side < 0 ? kCandLimitLow : kCandLimitHigh;
          cs.prm[0] = m->jnt_range[2 * j + (side + 1) / 2];
          cs.add(dof, -side, 0);
          cands.push_back(cs);
        }
      } else if (type == mjJNT_BALL) {
        c.kind = kCandLimitBall;
        c.prm[0] = std::max(m->jnt_range[2 * j], m->jnt_range[2 * j + 1]);
        for (int k = 0; k < 3; ++k) c.add(dof + k, 0, 0);
        cands.push_back(c);
      }
    }
    for (int t = 0; t < m->ntendon; ++t) {
      if (!m->tendon_limited[t]) continue;
      Cand c;
      c.type = mjCNSTR_LIMIT_TENDON;
      c.id = t;
      c.obj[0] = t;
      c.margin = m->tendon_margin[t];
      c.diag = m->tendon_invweight0[t];
      solver_params(m, m->tendon_solref_lim + 2 * t, m->tendon_solimp_lim + 5 * t, false, &c.K,
                    &c.B, c.solimp);
      for (int side = -1; side <= 1; side += 2) {
        Cand cs = c;
        cs.kind = side < 0 ? kCandTendonLow : kCandTendonHigh;
        cs.prm[0] = m->tendon_range[2 * t + (side + 1) / 2];
        for (int k = ten_adr[t]; k < ten_adr[t + 1]; ++k)
          cs.add(ten_dof[k], -side * ten_coef[k], 0);
        cands.push_back(cs);
      }
    }
  }

  // the Newton Hessian keeps the mass matrix's sparsity: every row's dofs must lie on one chain
  for (const Cand& c : cands)
    for (size_t a = 0; a < c.dof.size(); ++a)
      for (size_t b = 0; b < a; ++b)
        if (!is_ancestor_or_self(m, c.dof[b], c.dof[a]))
          unsupported("constraint row of type " + std::to_string(c.type) + " id " +
                      std::to_string(c.id) + " couples dofs " + std::to_string(c.dof[b]) +
                      " and " + std::to_string(c.dof[a]) +
                      ", which are not on one kinematic chain (the engine's Hessian shares "
                      "the mass matrix's tree sparsity)");

  // candidate tables
  s.ncand = static_cast<int>(cands.size());
  cand_adr.assign(1, 0);
  std::map<int, std::vector<std::pair<int, int>>> hcontrib;  // qM address -> (a, b)
  for (int ci = 0; ci < s.ncand; ++ci) {
    const Cand& c = cands[ci];
    cand_kind.push_back(c.kind);
    cand_type.push_back(c.type);
    cand_id.push_back(c.id);
    cand_obj.push_back(c.obj[0]);
    cand_obj.push_back(c.obj[1]);
    cand_K.push_back(c.K);
    cand_B.push_back(c.B);
    for (int k = 0; k < 5; ++k) cand_solimp.push_back(c.solimp[k]);
    cand_diag.push_back(c.diag);
    cand_margin.push_back(c.margin);
    cand_floss.push_back(c.floss);
    for (int k = 0; k < 5; ++k) cand_prm.push_back(c.prm[k]);
    cand_ref.push_back(c.ref[0]);
    cand_ref.push_back(c.ref[1]);
    const int first = cand_adr.back();
    for (size_t k = 0; k < c.dof.size(); ++k) {
      cand_dof.push_back(c.dof[k]);
      cand_c1.push_back(c.c1[k]);
      cand_c2.push_back(c.c2[k]);
      nnz_cand.push_back(ci);
    }
    cand_adr.push_back(static_cast<int>(cand_dof.size()));
    // Hessian contributions: row dof a (the descendant), column dof b
    for (int a = first; a < cand_adr.back(); ++a)
      for (int b = first; b <= a; ++b) {
        const int addr = dof_Madr[cand_dof[a]] + chain_offset(m, cand_dof[a], cand_dof[b]);
        hcontrib[addr].push_back({a, b});
      }
  }
  s.ncandnnz = static_cast<int>(cand_dof.size());
  hent_adr.assign(1, 0);
  for (const auto& [addr, list] : hcontrib) {
    hent_addr.push_back(addr);
    for (const auto& [a, b] : list) {
      hcon_a.push_back(a);
      hcon_b.push_back(b);
    }
    hent_adr.push_back(static_cast<int>(hcon_a.size()));
  }
  s.nhent = static_cast<int>(hent_addr.size());
  s.nhcon = static_cast<int>(hcon_a.size());
  group_by(cand_dof, m->nv, dof_candadr, dof_candent);
  s.ndofcand = s.ncandnnz;

  // every table has the length its declaration states
#define BIDEX_X(name, count, doc)                                                       \
  if (static_cast<long>(name.size()) != static_cast<long>(count))                       \
    throw std::logic_error(std::string("gpu::ModelArrays: ") + #name + " has " +        \
                           std::to_string(name.size()) + " entries, expected " +        \
                           std::to_string(count));
  BIDEX_GPU_MODEL_REALS(BIDEX_X)
  BIDEX_GPU_MODEL_INTS(BIDEX_X)
#undef BIDEX_X
}

template <class T>
PackedModel<T>::PackedModel(const ModelArrays& a) : s_(a.s) {
  const Sizes& s = a.s;
  opt_.timestep = static_cast<T>(a.opt.timestep);
  for (int k = 0; k < 3; ++k) opt_.gravity[k] = static_cast<T>(a.opt.gravity[k]);
  opt_.meaninertia = static_cast<T>(a.opt.meaninertia);
  double tol = a.opt.tolerance;
  if (sizeof(T) < sizeof(double)) tol = std::max(tol, a.options.float_tolerance_floor);
  opt_.tolerance = static_cast<T>(tol);
  opt_.iterations = a.opt.iterations;
  opt_.disableflags = a.opt.disableflags;
  opt_.warmstart = a.opt.warmstart;
  opt_.implicit_damping = a.opt.implicit_damping;

  // lay the arrays out one after another, each aligned to 16 bytes
  size_t at = 0;
  auto place = [&](size_t bytes) {
    at = (at + 15) & ~size_t(15);
    offsets_.push_back(at);
    at += bytes;
  };
#define BIDEX_X(name, count, doc) place(sizeof(T) * static_cast<size_t>(count));
  BIDEX_GPU_MODEL_REALS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc) place(sizeof(int) * static_cast<size_t>(count));
  BIDEX_GPU_MODEL_INTS(BIDEX_X)
#undef BIDEX_X
  bytes_.assign((at + 15) & ~size_t(15), std::byte{0});

  // copy (reals converted to T)
  size_t k = 0;
#define BIDEX_X(name, count, doc)                                                 \
  {                                                                               \
    T* dst = reinterpret_cast<T*>(bytes_.data() + offsets_[k++]);                 \
    for (size_t i = 0; i < a.name.size(); ++i) dst[i] = static_cast<T>(a.name[i]); \
  }
  BIDEX_GPU_MODEL_REALS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc)                                                           \
  if (!a.name.empty())                                                                      \
    std::memcpy(bytes_.data() + offsets_[k], a.name.data(), sizeof(int) * a.name.size()); \
  ++k;
  BIDEX_GPU_MODEL_INTS(BIDEX_X)
#undef BIDEX_X
  (void)s;
}

template <class T>
Model<T> PackedModel<T>::view(const std::byte* base) const {
  Model<T> m;
  m.s = s_;
  m.opt = opt_;
  size_t k = 0;
#define BIDEX_X(name, count, doc) m.name = reinterpret_cast<const T*>(base + offsets_[k++]);
  BIDEX_GPU_MODEL_REALS(BIDEX_X)
#undef BIDEX_X
#define BIDEX_X(name, count, doc) m.name = reinterpret_cast<const int*>(base + offsets_[k++]);
  BIDEX_GPU_MODEL_INTS(BIDEX_X)
#undef BIDEX_X
  return m;
}

template class PackedModel<double>;
template class PackedModel<float>;

}  // namespace bidex::sim::gpu
