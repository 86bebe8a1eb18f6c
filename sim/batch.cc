#include "sim/batch.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>

#include <mujoco/mujoco.h>
#include <omp.h>

#include "core/error.h"

namespace bidex::sim {

namespace {

// MuJoCo prints every warning by default; in a batch they are counted per slot instead
// (d->warning) and surface as fault flags, so the global printer stays quiet.
void quiet_warning(const char*) {}

// MuJoCo ends the process on an engine error (a full arena, for one) unless the user handler
// leaves it; thrown instead, the error unwinds to the slot's step, which flags and resets that
// slot alone.
struct MujocoError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
void throw_error(const char* msg) { throw MujocoError(msg); }

void install_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_warning = quiet_warning;
    mju_user_error = throw_error;
  });
}

bool all_finite(const double* x, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(x[i])) return false;
  return true;
}

}  // namespace

double uniform(std::mt19937_64& rng, double lo, double hi) {
  const double u = static_cast<double>(rng() >> 11) * 0x1.0p-53;
  return lo + (hi - lo) * u;
}

SimBatch::SimBatch(const SimModel& model, int nslot, BatchOptions options)
    : model_(&model), nslot_(nslot), seed_(options.seed) {
  if (nslot <= 0)
    throw ConfigError("", "batch.nslot", "a slot count > 0", std::to_string(nslot));
  install_handlers();
  set_threads(options.threads);
  const SimModel& m = model;

  // contiguous arrays (NaN-filled in debug builds, so an unwritten value shows)
#ifdef BIDEX_NAN_FILL
  const double fill = std::numeric_limits<double>::quiet_NaN();
#else
  const double fill = 0.0;
#endif
#define BIDEX_X(name, width, doc) \
  name##_width = (width);         \
  name.assign(static_cast<size_t>(nslot) * name##_width, fill);
  BIDEX_BATCH_INPUTS(BIDEX_X)
  BIDEX_BATCH_OUTPUTS(BIDEX_X)
#undef BIDEX_X
  time.assign(nslot, 0.0);
  fault.assign(nslot, 0);
  fault_count.assign(nslot, 0);
  efc_rows.assign(nslot, 0);
  solver_iters.assign(nslot, 0);
  episode.assign(nslot, -1);
  warnings_seen_.assign(nslot, 0);
  rng_.resize(nslot);
  for (int s = 0; s < nslot; ++s) rng_[s] = SlotRng::make(seed_, static_cast<uint32_t>(s), 0);

  // one mjData per slot; then every slot starts from the initial state
  data_.assign(nslot, nullptr);
  for (int s = 0; s < nslot; ++s) {
    data_[s] = mj_makeData(m.mj());
    if (!data_[s]) throw std::bad_alloc();
  }
  reset_all(m, *this);
}

SimBatch::~SimBatch() {
  for (mjData* d : data_)
    if (d) mj_deleteData(d);
}

void SimBatch::set_threads(int n) { threads_ = n > 0 ? n : omp_get_max_threads(); }

SlotView SimBatch::slot(int s) {
  SlotView v;
#define BIDEX_X(name, width, doc) v.name = name.data() + static_cast<size_t>(s) * name##_width;
  BIDEX_BATCH_INPUTS(BIDEX_X)
  BIDEX_BATCH_OUTPUTS(BIDEX_X)
#undef BIDEX_X
  return v;
}

int64_t SimBatch::total_faults() const {
  int64_t n = 0;
  for (auto c : fault_count) n += c;
  return n;
}

size_t SimBatch::bytes() const {
  size_t b = static_cast<size_t>(nslot_) * model_->data_bytes();
#define BIDEX_X(name, width, doc) b += name.size() * sizeof(double);
  BIDEX_BATCH_INPUTS(BIDEX_X)
  BIDEX_BATCH_OUTPUTS(BIDEX_X)
#undef BIDEX_X
  b += rng_.size() * sizeof(SlotRng) +
       nslot_ * (sizeof(double) + sizeof(uint32_t) + 2 * sizeof(int64_t) + sizeof(int));
  return b;
}

namespace {

// copies a slot's MuJoCo state into its rows of the contiguous output arrays
void write_outputs(const mjData* d, SimBatch& b, int s) {
  SlotView v = b.slot(s);
#define BIDEX_X(name, width, doc) std::memcpy(v.name, d->name, sizeof(double) * b.name##_width);
  BIDEX_BATCH_OUTPUTS(BIDEX_X)
#undef BIDEX_X
  b.time[s] = d->time;
}

}  // namespace

int warning_total(const mjData* d) {
  int n = 0;
  for (int i = 0; i < mjNWARNING; ++i) n += d->warning[i].number;
  return n;
}

void update_base_wrench(const SimModel& model, mjData* d, const double* wrench) {
  const auto& hands = model.hands();
  for (size_t h = 0; h < hands.size(); ++h) {
    if (!hands[h].free_base) continue;
    // xfrc_applied acts at the body's centre of mass: move the force to the pivot
    const int b = hands[h].root_body;
    const double* f = wrench + h * 6;
    double r[3], moment[3];
    for (int k = 0; k < 3; ++k) r[k] = d->xpos[3 * b + k] - d->xipos[3 * b + k];
    mju_cross(moment, r, f);
    double* row = d->xfrc_applied + b * 6;
    for (int k = 0; k < 3; ++k) {
      row[k] = f[k];
      row[3 + k] = f[3 + k] + moment[k];
    }
  }
}

void apply_inputs(const SimModel& model, mjData* d, const double* ctrl, const double* wrench) {
  std::memcpy(d->ctrl, ctrl, sizeof(double) * model.mj()->nu);
  update_base_wrench(model, d, wrench);
}

void reset_slot(const SimModel& model, SimBatch& b, int s, bool forward) {
  const mjModel* m = model.mj();
  mjData* d = b.data_[s];
  mj_resetData(m, d);

  // position targets at the current joint angles (inside the control range)
  for (int a = 0; a < m->nu; ++a) {
    double target = 0;
    if (m->actuator_trntype[a] == mjTRN_JOINT)
      target = d->qpos[m->jnt_qposadr[m->actuator_trnid[2 * a]]];
    if (m->actuator_ctrllimited[a])
      target = std::clamp(target, m->actuator_ctrlrange[2 * a], m->actuator_ctrlrange[2 * a + 1]);
    d->ctrl[a] = target;
  }
  SlotView v = b.slot(s);
  std::fill(v.base_wrench, v.base_wrench + b.base_wrench_width, 0.0);
  std::memcpy(v.ctrl, d->ctrl, sizeof(double) * m->nu);
  apply_inputs(model, d, v.ctrl, v.base_wrench);

  // a new episode: its own random stream
  b.episode[s] += 1;
  b.rng_[s].rekey(static_cast<uint64_t>(b.episode[s]));
  if (forward) sync_slot(model, b, s);
}

void reset_all(const SimModel& model, SimBatch& b) {
#pragma omp parallel for schedule(static) num_threads(b.threads())
  for (int s = 0; s < b.nslot(); ++s) reset_slot(model, b, s);
}

void sync_slot(const SimModel& model, SimBatch& b, int s) {
  mjData* d = b.data_[s];
  mj_forward(model.mj(), d);
  b.warnings_seen_[s] = warning_total(d);
  write_outputs(d, b, s);
}

int solver_iterations(const mjData* d) {
  int iters = d->solver_niter[0];
  for (int i = 1; i < std::min(d->nisland, mjNISLAND); ++i)
    iters = std::max(iters, d->solver_niter[i]);
  return iters;
}

void step_slot(const SimModel& model, SimBatch& b, int s) {
  const mjModel* m = model.mj();
  const int substeps = model.physics().substeps;
  const double max_speed = model.physics().max_speed;
  const int nu = m->nu, nw = b.base_wrench_width;
  mjData* d = b.data_[s];
  const double* ctrl = b.ctrl.data() + static_cast<size_t>(s) * nu;
  const double* wrench = b.base_wrench.data() + static_cast<size_t>(s) * nw;
  uint32_t f = kFaultNone;

  // 1. inputs
  if (!all_finite(ctrl, nu) || !all_finite(wrench, nw)) {
    f |= kFaultBadInput;
  } else {
    // 2. physics: step2 then step1 keeps positions, velocities and sensors consistent with
    // the new state at the end (same cost as mj_step)
    const double t0 = d->time;
    try {
      apply_inputs(model, d, ctrl, wrench);
      for (int k = 0; k < substeps; ++k) {
        if (k > 0) update_base_wrench(model, d, wrench);  // the pivot moves with the base
        mj_step2(m, d);
        mj_step1(m, d);
      }
      b.efc_rows[s] += d->nefc;
      b.solver_iters[s] += solver_iterations(d);
    } catch (const MujocoError&) {
      f |= kFaultMujocoError;
    }

    // 3. faults (MuJoCo resets a slot itself on a bad acceleration: time goes back)
    if (f == kFaultNone) {
      if (!all_finite(d->qpos, m->nq) || !all_finite(d->qvel, m->nv) ||
          !all_finite(d->qacc, m->nv))
        f |= kFaultNonFinite;
      double vmax = 0;
      for (int i = 0; i < m->nv; ++i) vmax = std::max(vmax, std::abs(d->qvel[i]));
      if (vmax > max_speed) f |= kFaultExploded;
      if (warning_total(d) != b.warnings_seen_[s] || d->time < t0) f |= kFaultMujocoWarn;
    }
  }

  // 4. outputs, or a reset of a faulty slot
  b.fault[s] = f;
  if (f != kFaultNone) {
    b.fault_count[s] += 1;
    reset_slot(model, b, s);
  } else {
    write_outputs(d, b, s);
  }
}

void step(const SimModel& model, SimBatch& b, const std::function<void(int)>* post,
          const std::function<void(int)>* pre) {
#pragma omp parallel for schedule(static) num_threads(b.threads())
  for (int s = 0; s < b.nslot(); ++s) {
    if (pre) (*pre)(s);
    step_slot(model, b, s);  // 1-4
    if (post) (*post)(s);    // 5. per-slot work of the caller
  }
}

void random_inputs(const SimModel& model, SimBatch& b, double max_force, double max_torque) {
  const mjModel* m = model.mj();
  const auto& hands = model.hands();
#pragma omp parallel for schedule(static) num_threads(b.threads())
  for (int s = 0; s < b.nslot(); ++s) {
    auto& rng = b.rng(s);
    SlotView v = b.slot(s);
    for (int a = 0; a < m->nu; ++a)
      v.ctrl[a] = rng.uniform(m->actuator_ctrlrange[2 * a], m->actuator_ctrlrange[2 * a + 1]);
    for (size_t h = 0; h < hands.size(); ++h) {
      double* w = v.base_wrench + h * 6;
      for (int k = 0; k < 6; ++k) {
        double lim = k < 3 ? max_force : max_torque;
        w[k] = hands[h].free_base ? rng.uniform(-lim, lim) : 0.0;
      }
    }
  }
}

}  // namespace bidex::sim
