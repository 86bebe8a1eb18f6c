#include "tasks/env.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include <omp.h>

#include "core/error.h"
#include "sim/hand_spec.h"
#include "sim/physics.h"
#include "sim/scene.h"
#include "tasks/math.h"

namespace bidex::tasks {

namespace {
constexpr int kPad = 8;  // doubles per thread in thread_times_ (one cache line)
double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

void random_actions(std::vector<float>& actions, std::mt19937_64& rng) {
  for (auto& a : actions) a = static_cast<float>(sim::uniform(rng, -1, 1));
}

std::unique_ptr<sim::SimModel> build_task_model(Task& task, const std::string& hand_file,
                                                const std::string& physics_file, bool on_gpu) {
  sim::HandSpec hand =
      sim::load_hand_spec(hand_file.empty() ? sim::default_hand_path() : hand_file);
  sim::PhysicsOptions physics =
      sim::load_physics(physics_file.empty() ? sim::default_physics_path() : physics_file);
  if (on_gpu) physics = physics.on_gpu();
  auto model = std::make_unique<sim::SimModel>(task.scene(hand, physics).build(
      task.spec().versioned_id() + " scene (" + task.config_file() + ")"));
  task.bind(*model);
  return model;
}

TaskEnv::TaskEnv(std::unique_ptr<Task> task, const EnvOptions& o) : task_(std::move(task)) {
  if (o.nslot <= 0)
    throw ConfigError("", "nslot", "a slot count > 0", std::to_string(o.nslot));
  const TaskSpec& sp = task_->spec();
  model_ = build_task_model(*task_, o.hand_file, o.physics_file);
  batch_ = std::make_unique<sim::SimBatch>(*model_, o.nslot, sim::BatchOptions{o.threads, o.seed});

  nslot_ = o.nslot;
  obs_dim_ = sp.obs.dim();
  act_dim_ = sp.act.dim();
  nterms_ = static_cast<int>(sp.reward_terms.size());
  episode_length_ = task_->episode_length();
  if (nterms_ > kMaxTerms)
    throw Error(sp.id + ": " + std::to_string(nterms_) + " reward terms, at most " +
                std::to_string(kMaxTerms) + " supported");
  if (act_dim_ > kMaxActions)
    throw Error(sp.id + ": " + std::to_string(act_dim_) + " actions, at most " +
                std::to_string(kMaxActions) + " supported");
  const size_t n = static_cast<size_t>(nslot_);
  obs.assign(n * obs_dim_, 0.f);
  final_obs.assign(n * obs_dim_, 0.f);
  reward.assign(n, 0.f);
  terms.assign(n * nterms_, 0.f);
  terminated.assign(n, 0);
  truncated.assign(n, 0);
  success.assign(n, 0);
  fault.assign(n, 0);
  state_.assign(n, SlotState{});
  ep_return_.assign(n, 0.0);
  ep_terms_.assign(n * nterms_, 0.0);
  done_return_.assign(n, 0.0);
  done_terms_.assign(n * nterms_, 0.0);
  done_length_.assign(n, 0);
  ended_.assign(n, 0);
  stats_.term_sums.assign(nterms_, 0.0);
  // one row per thread that may step a slot (a pack's loop runs with the batch's thread count)
  thread_times_.assign(
      static_cast<size_t>(std::max(omp_get_max_threads(), batch_->threads()) + 1) * kPad, 0.0);
  reset();
}

TaskEnv::~TaskEnv() = default;

TaskSlot TaskEnv::slot(int s) {
  TaskSlot t;
  t.index = s;
  t.model = model_.get();
  t.state = batch_->slot(s);
  t.data = batch_->data(s);
  t.rng = &batch_->rng(s);
  t.task = &state_[s];
  return t;
}

void set_goal_shifts(const TaskSpec& spec, SlotState* states, int nslot,
                     const std::vector<int>& slots, const std::vector<double>& shifts) {
  const std::string where = "task " + spec.id + ": goal shifts: ";
  const int k = spec.goal_shifts;
  if (k == 0) throw Error(where + "the task takes no per-slot goal");
  if (shifts.size() != slots.size() * static_cast<size_t>(k) * 3)
    throw Error(where + "expected " + std::to_string(k * 3) + " values per slot (" +
                std::to_string(slots.size() * k * 3) + " for " + std::to_string(slots.size()) +
                " slots), got " + std::to_string(shifts.size()));
  for (size_t i = 0; i < slots.size(); ++i) {
    if (slots[i] < 0 || slots[i] >= nslot)
      throw Error(where + "slot " + std::to_string(slots[i]) + " is outside 0.." +
                  std::to_string(nslot - 1));
    for (int j = 0; j < k * 3; ++j)
      if (!std::isfinite(shifts[i * k * 3 + j]))
        throw Error(where + "slot " + std::to_string(slots[i]) + " has a non-finite value");
  }
  for (size_t i = 0; i < slots.size(); ++i)
    for (int g = 0; g < k; ++g)
      for (int c = 0; c < 3; ++c)
        states[slots[i]].params.goal_shift[g][c] = shifts[(i * k + g) * 3 + c];
}

void TaskEnv::set_goal_shifts(const std::vector<int>& slots, const std::vector<double>& shifts) {
  tasks::set_goal_shifts(spec(), state_.data(), nslot_, slots, shifts);
}

void TaskEnv::start_episode(int s) {
  new_episode(state_[s]);
  ep_return_[s] = 0;
  std::fill_n(ep_terms_.data() + static_cast<size_t>(s) * nterms_, nterms_, 0.0);
  TaskSlot t = slot(s);
  task_->reset(t);
  sim::sync_slot(*model_, *batch_, s);
}

void TaskEnv::restart(int s) {
  sim::reset_slot(*model_, *batch_, s, /*forward=*/false);
  start_episode(s);
  TaskSlot t = slot(s);
  float* o = obs.data() + static_cast<size_t>(s) * obs_dim_;
  task_->observe(t, o);
  clip_observation(o, obs_dim_, kObsClip, state_[s]);
  clear_outputs(s);
  success[s] = 0;
  ended_[s] = 0;
}

void TaskEnv::clear_outputs(int s) {
  reward[s] = 0;
  std::fill_n(terms.data() + static_cast<size_t>(s) * nterms_, nterms_, 0.0f);
  terminated[s] = truncated[s] = fault[s] = 0;
}

void TaskEnv::reset() {
#pragma omp parallel for schedule(static) num_threads(batch_->threads())
  for (int s = 0; s < nslot_; ++s) restart(s);
}

void TaskEnv::reset_slots(const uint8_t* mask) {
#pragma omp parallel for schedule(static) num_threads(batch_->threads())
  for (int s = 0; s < nslot_; ++s)
    if (mask[s]) restart(s);
}

void TaskEnv::post_step(int s) {
  const double t0 = profile_on_ ? now() : 0;
  SlotState& st = state_[s];
  TaskSlot t = slot(s);
  // a slot the simulation faulted was reset by it; one whose reward or observation was not
  // finite is faulted here (tasks/README.md, "Faults"), and its simulation is reset below
  const bool sim_fault = batch_->fault[s] != sim::kFaultNone;
  bool faulted = sim_fault || st.nonfinite_obs;
  double tv_[kMaxTerms] = {};
  bool term = false, trunc = false;
  if (!faulted) {
    st.progress += 1;
    term = task_->evaluate(t, tv_);
    faulted = !math::all_finite(tv_, nterms_);
  }
  float* fo = final_obs.data() + static_cast<size_t>(s) * obs_dim_;
  if (!faulted) {
    trunc = !term && st.progress >= episode_length_;
    if (term || trunc) {
      task_->observe(t, fo);
      faulted = !math::clip_finite(fo, obs_dim_, kObsClip);
    }
  }
  if (faulted) {
    term = false;
    trunc = true;  // the episode is cut short
    std::fill_n(tv_, nterms_, 0.0);
    if (sim_fault) {  // its last state is the simulation's reset state
      task_->observe(t, fo);
      math::clip_finite(fo, obs_dim_, kObsClip);
    } else {
      std::fill_n(fo, obs_dim_, 0.0f);
    }
  }
  double r = 0;
  float* trow = terms.data() + static_cast<size_t>(s) * nterms_;
  double* erow = ep_terms_.data() + static_cast<size_t>(s) * nterms_;
  for (int k = 0; k < nterms_; ++k) {
    r += tv_[k];
    trow[k] = static_cast<float>(tv_[k]);
    erow[k] += tv_[k];
  }
  reward[s] = static_cast<float>(r);
  ep_return_[s] += r;
  terminated[s] = term;
  truncated[s] = trunc;
  success[s] = st.success;
  fault[s] = faulted;
  float* o = obs.data() + static_cast<size_t>(s) * obs_dim_;
  if (term || trunc) {
    done_return_[s] = ep_return_[s];
    done_length_[s] = st.progress;
    std::copy_n(erow, nterms_, done_terms_.data() + static_cast<size_t>(s) * nterms_);
    if (autoreset_) {
      if (!sim_fault) sim::reset_slot(*model_, *batch_, s, /*forward=*/false);
      start_episode(s);
    } else {  // the slot stays at its end, its observation the final one
      ended_[s] = 1;
      std::copy_n(fo, obs_dim_, o);
    }
  }
  if (!ended_[s]) {
    task_->observe(t, o);
    clip_observation(o, obs_dim_, kObsClip, st);
  }
  if (profile_on_) thread_times_[omp_get_thread_num() * kPad + 1] += now() - t0;
}

void TaskEnv::step(const std::vector<float>& actions) {
  if (actions.size() != static_cast<size_t>(nslot_) * act_dim_)
    throw Error(spec().id + ": step expects " + std::to_string(nslot_) + " x " +
                std::to_string(act_dim_) + " actions, got " + std::to_string(actions.size()));
  step(actions.data());
}

void TaskEnv::step(const float* actions) {
  begin_step(actions);
#pragma omp parallel for schedule(static) num_threads(batch_->threads())
  for (int s = 0; s < nslot_; ++s) step_slot(s);
  end_step();
}

void TaskEnv::begin_step(const float* actions, int stride) {
  if (stride == 0) stride = act_dim_;
  if (stride < act_dim_)
    throw Error(spec().id + ": an action stride of " + std::to_string(stride) +
                " floats, narrower than the task's " + std::to_string(act_dim_) + " actions");
  step_t0_ = profile_on_ ? now() : 0;
  actions_ = actions;
  action_stride_ = stride;
}

void TaskEnv::step_slot(int s) {
  if (ended_[s]) {  // autoreset off: held at its end until reset_slots (obs unchanged)
    clear_outputs(s);
    return;
  }
  // 1. actions -> the slot's ctrl and base wrench rows
  {
    const double t0 = profile_on_ ? now() : 0;
    SlotState& st = state_[s];
    const float* a = actions_ + static_cast<size_t>(s) * action_stride_;
    for (int k = 0; k < act_dim_; ++k) st.action[k] = std::clamp(a[k], -1.0f, 1.0f);
    TaskSlot t = slot(s);
    task_->apply_actions(st.action.data(), t);
    if (profile_on_) thread_times_[omp_get_thread_num() * kPad] += now() - t0;
  }
  // 2. physics (and the reset of a faulty slot)
  sim::step_slot(*model_, *batch_, s);
  // 3-5. evaluate, reset of a finished slot, observe
  post_step(s);
}

void TaskEnv::end_step() {
  actions_ = nullptr;
  // episode records, in slot order (the same totals for any thread count)
  for (int s = 0; s < nslot_; ++s) {
    if (fault[s]) stats_.faults += 1;
    if (!terminated[s] && !truncated[s]) continue;
    stats_.episodes += 1;
    stats_.successes += success[s];
    stats_.terminated += terminated[s];
    stats_.truncated += truncated[s];
    stats_.return_sum += done_return_[s];
    stats_.length_sum += done_length_[s];
    const double* dt = done_terms_.data() + static_cast<size_t>(s) * nterms_;
    for (int k = 0; k < nterms_; ++k) stats_.term_sums[k] += dt[k];
  }
  if (profile_on_) {
    profile_.steps += 1;
    profile_.wall += now() - step_t0_;
  }
}

void add_levels(EpisodeStats& st, const SlotState* states, int n) {
  for (int s = 0; s < n; ++s)
    if (states[s].params.level_started) {
      st.level_sum += states[s].params.level;
      st.levels += 1;
    }
}

void set_levels(const Task& task, SlotState* states, int nslot, double level) {
  const std::string where = "task " + task.spec().id + ": curriculum level: ";
  if (!task.curriculum())
    throw Error(where + "its configuration (" + task.config_file() + ") has no curriculum");
  if (!(level >= 0 && level <= 1))
    throw Error(where + "expected a level in [0, 1], got " + std::to_string(level));
  for (int s = 0; s < nslot; ++s) {
    states[s].params.level = level;
    states[s].params.level_started = true;
  }
}

void TaskEnv::set_levels(double level) { tasks::set_levels(*task_, state_.data(), nslot_, level); }

EpisodeStats TaskEnv::take_stats() {
  EpisodeStats out = stats_;
  if (task_->curriculum()) add_levels(out, state_.data(), nslot_);
  stats_ = EpisodeStats{};
  stats_.term_sums.assign(nterms_, 0.0);
  return out;
}

void TaskEnv::set_profile(bool on) {
  profile_on_ = on;
  profile_ = StageProfile{};
  std::fill(thread_times_.begin(), thread_times_.end(), 0.0);
}

StageProfile TaskEnv::profile() const {
  StageProfile p = profile_;
  for (size_t i = 0; i + 1 < thread_times_.size(); i += kPad) {
    p.actions += thread_times_[i];
    p.task += thread_times_[i + 1];
  }
  return p;
}

}  // namespace bidex::tasks
