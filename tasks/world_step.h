// One world's share of a task step on the GPU backend, written once for host and device: what
// TaskEnv::step_slot and post_step do for a CPU slot, over world-major float32 arrays. WarpTaskEnv
// (tasks/warp_env.h) runs these as CUDA kernels on a GPU and as a host loop on Warp's CPU device.
// `B` adapts one family's stage bodies (tasks/gpu_families.h).
#pragma once

#include <cstdint>
#include <type_traits>

#include "core/hd.h"
#include "core/rng.h"
#include "sim/state_view.h"
#include "tasks/math.h"
#include "tasks/slot_state.h"

namespace bidex::tasks {

// Every per-world array a task step touches: the backend's (sim/warp_backend.h) and the env's.
struct WorldArrays {
  // backend state, world-major float32
  float *qpos, *qvel, *qfrc_actuator, *qfrc_constraint, *sensordata, *xpos, *xquat, *cvel,
      *subtree_com, *ctrl, *base_wrench, *mocap_pos, *mocap_quat;
  int nq, nv, nsensordata, nbody, nu, nwrench, nmocap;
  const uint32_t* fault;  // the step's fault bits (sim::FaultBits)
  int32_t* reset;         // 1: the world starts a new episode at the next reset pass
  // the env's
  const float* actions;   // nworld x act_stride
  int act_stride;
  SlotState* state;
  SlotRng* rng;
  float *obs, *final_obs, *reward, *terms;
  uint8_t *terminated, *truncated, *success, *faulted;
  double *ep_return, *ep_terms;
  // finished episodes since the host last took them, per world
  double *done_return, *done_length, *done_terms;
  int64_t *done_episodes, *done_successes, *done_terminated, *done_truncated, *done_faults;
  int obs_dim, act_dim, nterms, episode_length;
  uint64_t seed;
  float obs_clip;
  // autoreset (TaskEnv::set_autoreset): 1, a finished world starts its next episode within the
  // step; 0, it is held at its end (held[w]: its actions ignored, no reward, no flags, its obs
  // the final one; the physics still steps it) until a reset pass outside the step
  uint8_t* held;
  int autoreset = 1;
  int clearing = 0;  // 1 in a reset pass outside the step: it restarts held worlds too and
                     // clears the outputs (reward, terms, flags) of the worlds it resets
};

BIDEX_HD inline sim::WorldRows<float> world_rows(const WorldArrays& a, int w) {
  sim::WorldRows<float> r;
  r.qpos = a.qpos + static_cast<int64_t>(w) * a.nq;
  r.qvel = a.qvel + static_cast<int64_t>(w) * a.nv;
  r.qfrc_actuator = a.qfrc_actuator + static_cast<int64_t>(w) * a.nv;
  r.qfrc_constraint = a.qfrc_constraint + static_cast<int64_t>(w) * a.nv;
  r.sensordata = a.sensordata + static_cast<int64_t>(w) * a.nsensordata;
  r.xpos = a.xpos + static_cast<int64_t>(w) * a.nbody * 3;
  r.xquat = a.xquat + static_cast<int64_t>(w) * a.nbody * 4;
  r.cvel = a.cvel + static_cast<int64_t>(w) * a.nbody * 6;
  r.subtree_com = a.subtree_com + static_cast<int64_t>(w) * a.nbody * 3;
  r.ctrl = a.ctrl + static_cast<int64_t>(w) * a.nu;
  r.base_wrench = a.base_wrench + static_cast<int64_t>(w) * a.nwrench;
  r.mocap_pos = a.mocap_pos + static_cast<int64_t>(w) * a.nmocap * 3;
  r.mocap_quat = a.mocap_quat + static_cast<int64_t>(w) * a.nmocap * 4;
  return r;
}

BIDEX_HD inline sim::ResetRows<float> world_reset_rows(const WorldArrays& a, int w) {
  sim::ResetRows<float> r;
  r.qpos = a.qpos + static_cast<int64_t>(w) * a.nq;
  r.qvel = a.qvel + static_cast<int64_t>(w) * a.nv;
  r.ctrl = a.ctrl + static_cast<int64_t>(w) * a.nu;
  r.mocap_pos = a.mocap_pos + static_cast<int64_t>(w) * a.nmocap * 3;
  r.mocap_quat = a.mocap_quat + static_cast<int64_t>(w) * a.nmocap * 4;
  return r;
}

// A world's step outputs of nothing: no reward, no terms, no end, no fault (a held world's
// step, and a reset outside the step)
BIDEX_HD inline void clear_outputs(const WorldArrays& a, int w) {
  a.reward[w] = 0.0f;
  for (int k = 0; k < a.nterms; ++k) a.terms[static_cast<int64_t>(w) * a.nterms + k] = 0.0f;
  a.terminated[w] = a.truncated[w] = a.faulted[w] = 0;
}

// 1. actions, clipped to [-1, 1] and kept for the observation, -> ctrl and base_wrench rows
template <class B>
BIDEX_HD void world_apply(const typename B::Program& p, const WorldArrays& a, int w) {
  if (a.held[w]) return;  // its actions are ignored
  SlotState& st = a.state[w];
  const float* in = a.actions + static_cast<int64_t>(w) * a.act_stride;
  for (int k = 0; k < a.act_dim; ++k) {
    const float x = in[k];
    // a NaN passes through to the physics, which flags and resets the world (as on the CPU)
    st.action[k] = x < -1.0f ? -1.0f : (x > 1.0f ? 1.0f : x);
  }
  B::apply(p, st.action.data(), world_rows(a, w));
}

// 3. after physics: reward terms, termination, time limit; a finished episode's record and
// final observation; marks the world for the reset pass. A faulted world ends its episode
// (truncated) with zero reward and a zero final observation: one the physics faulted (its state
// is not finite), one whose last observation had a non-finite value, or one whose reward terms
// or final observation are not finite now (tasks/README.md, "Faults").
template <class B>
BIDEX_HD void world_evaluate(const typename B::Program& p, const WorldArrays& a, int w) {
  if (a.held[w]) {  // held at its end (autoreset off): nothing is paid, nothing ends
    clear_outputs(a, w);
    return;
  }
  SlotState& st = a.state[w];
  bool faulted = a.fault[w] != 0 || st.nonfinite_obs;
  float tv[kMaxTerms] = {};
  bool term = false, trunc = false;
  const sim::WorldRows<float> rows = world_rows(a, w);
  if (!faulted) {
    st.progress += 1;
    term = B::evaluate(p, rows, st, a.rng[w], tv);
    faulted = !math::all_finite(tv, a.nterms);
  }
  float* fo = a.final_obs + static_cast<int64_t>(w) * a.obs_dim;
  if (!faulted) {
    trunc = !term && st.progress >= a.episode_length;
    if (term || trunc) {
      B::observe(p, rows, st, fo);
      faulted = !math::clip_finite(fo, a.obs_dim, a.obs_clip);
    }
  }
  if (faulted) {
    term = false;
    trunc = true;
    for (int k = 0; k < a.nterms; ++k) tv[k] = 0.0f;
    for (int i = 0; i < a.obs_dim; ++i) fo[i] = 0.0f;
  }
  double r = 0;
  float* trow = a.terms + static_cast<int64_t>(w) * a.nterms;
  double* erow = a.ep_terms + static_cast<int64_t>(w) * a.nterms;
  for (int k = 0; k < a.nterms; ++k) {
    r += tv[k];
    trow[k] = tv[k];
    erow[k] += tv[k];
  }
  a.reward[w] = static_cast<float>(r);
  a.ep_return[w] += r;
  a.terminated[w] = term;
  a.truncated[w] = trunc;
  a.success[w] = st.success;
  a.faulted[w] = faulted;
  if (term || trunc) {
    a.done_return[w] += a.ep_return[w];
    a.done_length[w] += st.progress;
    double* drow = a.done_terms + static_cast<int64_t>(w) * a.nterms;
    for (int k = 0; k < a.nterms; ++k) drow[k] += erow[k];
    a.done_episodes[w] += 1;
    a.done_successes[w] += st.success;
    a.done_terminated[w] += term;
    a.done_truncated[w] += trunc;
    a.done_faults[w] += faulted;
    if (a.autoreset) {
      a.reset[w] = 1;
    } else {  // held: its observation stays the final one
      a.held[w] = 1;
      float* o = a.obs + static_cast<int64_t>(w) * a.obs_dim;
      for (int i = 0; i < a.obs_dim; ++i) o[i] = fo[i];
    }
  }
}

// 4. between the backend's reset passes: a marked world's new episode (its own random stream,
// keyed by run seed, world and episode, as the CPU slot's)
template <class B>
BIDEX_HD void world_reset(const typename B::Program& p, const WorldArrays& a, int w) {
  if (!a.reset[w]) return;
  if (a.held[w] && !a.clearing) return;  // a held world the fault check marked waits
  if (a.clearing) {
    a.held[w] = 0;
    clear_outputs(a, w);
    a.success[w] = 0;
  }
  SlotRng& rng = a.rng[w];
  rng.rekey(rng.episode + 1);
  SlotState& st = a.state[w];
  new_episode(st);
  a.ep_return[w] = 0;
  for (int k = 0; k < a.nterms; ++k) a.ep_terms[static_cast<int64_t>(w) * a.nterms + k] = 0;
  B::reset(p, world_reset_rows(a, w), st, rng);
}

// 5. the observation row, clipped; a non-finite value is set to 0 and faults the world at the
// next step
template <class B>
BIDEX_HD void world_observe(const typename B::Program& p, const WorldArrays& a, int w) {
  if (a.held[w]) return;  // its final observation stays
  float* o = a.obs + static_cast<int64_t>(w) * a.obs_dim;
  SlotState& st = a.state[w];
  B::observe(p, world_rows(a, w), st, o);
  clip_observation(o, a.obs_dim, a.obs_clip, st);
}

// The four stages by name, so that a runner writes its loop or kernel once for all of them.
enum class Stage { kApply, kEvaluate, kReset, kObserve };

inline const char* stage_name(Stage s) {
  switch (s) {
    case Stage::kApply: return "apply_actions";
    case Stage::kEvaluate: return "evaluate";
    case Stage::kReset: return "reset";
    case Stage::kObserve: return "observe";
  }
  return "?";
}

template <class B, Stage S>
BIDEX_HD void world_stage(const typename B::Program& p, const WorldArrays& a, int w) {
  if constexpr (S == Stage::kApply)
    world_apply<B>(p, a, w);
  else if constexpr (S == Stage::kEvaluate)
    world_evaluate<B>(p, a, w);
  else if constexpr (S == Stage::kReset)
    world_reset<B>(p, a, w);
  else
    world_observe<B>(p, a, w);
}

// Calls f(std::integral_constant<Stage, s>{}): a runtime stage to a compile-time one.
template <class F>
void with_stage(Stage s, F&& f) {
  switch (s) {
    case Stage::kApply: return f(std::integral_constant<Stage, Stage::kApply>{});
    case Stage::kEvaluate: return f(std::integral_constant<Stage, Stage::kEvaluate>{});
    case Stage::kReset: return f(std::integral_constant<Stage, Stage::kReset>{});
    case Stage::kObserve: return f(std::integral_constant<Stage, Stage::kObserve>{});
  }
}

}  // namespace bidex::tasks
