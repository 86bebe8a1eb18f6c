#include "taskpack/pack.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "core/error.h"
#include "taskpack/pack_row.h"
#include "tasks/registry.h"

namespace bidex::taskpack {

namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string entry_key(int g, const char* field) {
  std::string k = "entries[";
  k.append(std::to_string(g)).append("]");
  if (field && *field) k.append(".").append(field);
  return k;
}

// 'text' (built with append: GCC 12's -Wrestrict misfires on "'" + std::string)
std::string quoted(const std::string& s) {
  std::string q = "'";
  q.append(s).append("'");
  return q;
}


}  // namespace

const char* mode_name(PackMode m) {
  switch (m) {
    case PackMode::kPlain: return "plain";
    case PackMode::kMultiTask: return "multitask";
    case PackMode::kMeta: return "meta";
  }
  return "?";
}

uint64_t group_seed(uint64_t seed, int g) {
  return seed + static_cast<uint64_t>(g) * 0x9E3779B97F4A7C15ull;
}

Pack::Pack(const PackSpec& spec) : spec_(spec) {
  const std::string& name = spec_.name;
  const int n = static_cast<int>(spec_.entries.size());
  if (n == 0) throw ConfigError(name, "entries", "at least one entry", "none");

  // the entries: known tasks, slot counts, scales, unique labels (checked before any scene is
  // built, so a bad entry costs nothing)
  std::vector<const tasks::TaskSpec*>& specs = specs_;
  for (int g = 0; g < n; ++g) {
    PackEntry& e = spec_.entries[g];
    try {
      specs.push_back(&tasks::find_task(e.task).spec());
    } catch (const ConfigError& err) {
      throw ConfigError(name, entry_key(g, "task"), err.expected(), err.actual());
    }
    if (e.slots < 1)
      throw ConfigError(name, entry_key(g, "slots"), "a slot count >= 1", std::to_string(e.slots));
    if (!std::isfinite(e.reward_scale) || e.reward_scale < 0)
      throw ConfigError(name, entry_key(g, "reward_scale"), "a finite scale >= 0",
                        std::to_string(e.reward_scale));
    if (!e.goals.empty() && specs.back()->goal_shifts == 0)
      throw ConfigError(name, entry_key(g, "goals"), "no goals: task " + e.task +
                        " takes no per-slot goal", std::to_string(e.goals.size()) + " goals");
    for (const auto& x : e.goals)
      for (double v : x)
        if (!std::isfinite(v))
          throw ConfigError(name, entry_key(g, "goals"), "finite goal shifts", "a non-finite one");
    if (e.label.empty()) e.label = e.task;  // the spec kept by the pack names every entry
    const std::string& label = e.label;
    for (int h = 0; h < g; ++h)
      if (spec_.entries[h].label == label)
        throw ConfigError(name, entry_key(g, "label"),
                          std::string("a label unlike the other entries' (")
                              .append(entry_key(h, ""))
                              .append(" has it too)"),
                          quoted(label));
  }

  // widths
  for (auto [key, v] : {std::pair{"obs_pad", spec_.obs_pad}, std::pair{"act_pad", spec_.act_pad},
                        std::pair{"one_hot", spec_.one_hot}})
    if (v < 0) throw ConfigError(name, key, "a width >= 0 (0: automatic)", std::to_string(v));
  int obs_max = 0, act_max = 0;
  for (auto* s : specs) {
    obs_max = std::max(obs_max, s->obs.dim());
    act_max = std::max(act_max, s->act.dim());
  }
  obs_pad_ = spec_.obs_pad > 0 ? spec_.obs_pad : obs_max;
  act_dim_ = spec_.act_pad > 0 ? spec_.act_pad : act_max;
  for (int g = 0; g < n; ++g) {
    const auto& s = *specs[g];
    if (s.obs.dim() > obs_pad_)
      throw ConfigError(name, "obs_pad",
                        std::string("a width >= ").append(entry_key(g, "")).append(" (")
                            .append(s.id).append(")'s ").append(std::to_string(s.obs.dim()))
                            .append(" observations"),
                        std::to_string(spec_.obs_pad));
    if (s.act.dim() > act_dim_)
      throw ConfigError(name, "act_pad",
                        std::string("a width >= ").append(entry_key(g, "")).append(" (")
                            .append(s.id).append(")'s ").append(std::to_string(s.act.dim()))
                            .append(" actions"),
                        std::to_string(spec_.act_pad));
  }
  if (spec_.mode == PackMode::kMultiTask) {
    one_hot_ = spec_.one_hot > 0 ? spec_.one_hot : n;
    if (one_hot_ < n)
      throw ConfigError(name, "one_hot", std::string("a width >= the ").append(std::to_string(n)).append(" entries"),
                        std::to_string(spec_.one_hot));
  }
  obs_dim_ = obs_pad_ + one_hot_;

  // observation masks: the task's values pass, padding and (meta) goal slices are zeros
  for (int g = 0; g < n; ++g) {
    const auto& s = *specs[g];
    std::vector<uint8_t> keep(static_cast<size_t>(obs_pad_), 0);
    std::fill_n(keep.begin(), s.obs.dim(), uint8_t{1});
    if (spec_.mode == PackMode::kMeta)
      for (const auto& sl : s.obs.slices())
        if (sl.goal) std::fill_n(keep.begin() + sl.start, sl.size, uint8_t{0});
    keep_.push_back(std::move(keep));
  }
  for (int g = 0; g < n; ++g) {
    begin_.push_back(nslot_);
    nslot_ += spec_.entries[g].slots;
  }
  slot_group_.resize(static_cast<size_t>(nslot_));
  for (int g = 0; g < n; ++g)
    std::fill_n(slot_group_.begin() + begin_[g], spec_.entries[g].slots, g);
}

Pack::~Pack() = default;

Pack::PhysicsLoad Pack::take_load() {
  const LoadSums now = load_sums();
  PhysicsLoad load;
  const int64_t n = now.slot_steps - load_taken_.slot_steps;
  if (n > 0) {
    load.rows = static_cast<double>(now.rows - load_taken_.rows) / static_cast<double>(n);
    load.iterations =
        static_cast<double>(now.iterations - load_taken_.iterations) / static_cast<double>(n);
  }
  load_taken_ = now;
  return load;
}

int Pack::group_of(int slot) const { return slot_group_.at(static_cast<size_t>(slot)); }

int Pack::one_hot_offset() const {
  return spec_.mode == PackMode::kMultiTask ? obs_pad_ : -1;
}

void Pack::assign_goals() {
  for (int g = 0; g < ngroups(); ++g) {
    const PackEntry& e = spec_.entries[g];
    if (e.goals.empty()) continue;
    const int k = specs_[g]->goal_shifts;
    std::vector<int> local(e.slots);
    std::vector<double> shifts;
    shifts.reserve(static_cast<size_t>(e.slots) * k * 3);
    for (int i = 0; i < e.slots; ++i) {
      local[i] = i;
      for (int j = 0; j < k; ++j)
        shifts.insert(shifts.end(), e.goals[i % e.goals.size()].begin(),
                      e.goals[i % e.goals.size()].end());
    }
    set_goal_shifts(g, local, shifts);
  }
}

std::vector<int> Pack::slot_tasks(int* ntasks) const {
  std::vector<int> out;
  out.reserve(static_cast<size_t>(nslot()));
  int first = 0;
  for (const PackEntry& e : spec_.entries) {
    const int k = std::max<int>(1, static_cast<int>(e.goals.size()));
    for (int i = 0; i < e.slots; ++i) out.push_back(first + i % k);
    first += k;
  }
  if (ntasks) *ntasks = first;
  return out;
}

TaskPack::TaskPack(const PackSpec& spec, const PackOptions& options) : Pack(spec) {
  const int n = ngroups();
  // one env per entry, consecutive slots
  for (int g = 0; g < n; ++g) {
    const PackEntry& e = spec_.entries[g];
    tasks::EnvOptions o;
    o.nslot = e.slots;
    o.threads = options.threads;
    o.seed = group_seed(options.seed, g);
    o.hand_file = options.hand_file;
    o.physics_file = options.physics_file;
    envs_.push_back(std::make_unique<tasks::TaskEnv>(tasks::make_task(e.task, e.config), o));
  }
  assign_goals();
  for (int g = 0; g < n; ++g)
    if (!spec_.entries[g].goals.empty()) envs_[g]->reset();  // the first episodes take them

  const size_t ns = static_cast<size_t>(nslot_);
  obs.assign(ns * obs_dim_, 0.f);
  final_obs.assign(ns * obs_dim_, 0.f);
  reward.assign(ns, 0.f);
  terminated.assign(ns, 0);
  truncated.assign(ns, 0);
  success.assign(ns, 0);
  fault.assign(ns, 0);
  for (int s = 0; s < nslot_; ++s) write_row(slot_group_[s], s - begin_[slot_group_[s]], s);
}

TaskPack::~TaskPack() = default;

int TaskPack::threads() const { return envs_[0]->threads(); }

void TaskPack::write_row(int g, int local, int slot) {
  const tasks::TaskEnv& env = *envs_[g];
  const size_t od = static_cast<size_t>(env.obs_dim());
  const size_t row = static_cast<size_t>(slot) * obs_dim_;
  const uint8_t* keep = keep_[g].data();
  const int hot = hot_column(g);
  pack_row(env.obs.data() + local * od, keep, obs_pad_, obs_dim_, hot, obs.data() + row);
  reward[slot] = static_cast<float>(static_cast<double>(env.reward[local]) *
                                    spec_.entries[g].reward_scale);
  terminated[slot] = env.terminated[local];
  truncated[slot] = env.truncated[local];
  success[slot] = env.success[local];
  fault[slot] = env.fault[local];
  if (terminated[slot] || truncated[slot])
    pack_row(env.final_obs.data() + local * od, keep, obs_pad_, obs_dim_, hot,
             final_obs.data() + row);
}

void TaskPack::reset() {
  for (auto& e : envs_) e->reset();
  for (int s = 0; s < nslot_; ++s) write_row(slot_group_[s], s - begin_[slot_group_[s]], s);
}

void TaskPack::set_autoreset(bool on) {
  for (auto& e : envs_) e->set_autoreset(on);
}

void TaskPack::reset_slots(const uint8_t* mask) {
  for (int g = 0; g < ngroups(); ++g) envs_[g]->reset_slots(mask + begin_[g]);
  for (int s = 0; s < nslot_; ++s)
    if (mask[s]) write_row(slot_group_[s], s - begin_[slot_group_[s]], s);
}

void TaskPack::step(const std::vector<float>& actions) {
  if (actions.size() != static_cast<size_t>(nslot_) * act_dim_)
    throw Error(spec_.name + ": step expects " + std::to_string(nslot_) + " x " +
                std::to_string(act_dim_) + " actions, got " + std::to_string(actions.size()));
  step(actions.data());
}

void TaskPack::step(const float* actions) {
  const double w0 = profile_on_ ? now() : 0;
  // each entry reads its rows of the padded matrix in place (stride act_dim, no copy)
  for (size_t g = 0; g < envs_.size(); ++g)
    envs_[g]->begin_step(actions + static_cast<size_t>(begin_[g]) * act_dim_, act_dim_);
  // one loop over every slot of every entry; dynamic: the tasks differ in cost per slot
#pragma omp parallel for schedule(dynamic, 16) num_threads(threads())
  for (int s = 0; s < nslot_; ++s) {
    const int g = slot_group_[s];
    const int local = s - begin_[g];
    envs_[g]->step_slot(local);
    write_row(g, local, s);
  }
  for (auto& e : envs_) e->end_step();
  ++steps_;
  if (profile_on_) {
    wall_.steps += 1;
    wall_.wall += now() - w0;
  }
}

Pack::LoadSums TaskPack::load_sums() const {
  LoadSums sums;
  for (const auto& e : envs_) {
    const sim::SimBatch& b = e->batch();
    for (int64_t r : b.efc_rows) sums.rows += r;
    for (int64_t i : b.solver_iters) sums.iterations += i;
  }
  sums.slot_steps = steps_ * nslot_;
  return sums;
}

std::vector<tasks::EpisodeStats> TaskPack::take_stats() {
  std::vector<tasks::EpisodeStats> out;
  for (auto& e : envs_) out.push_back(e->take_stats());
  return out;
}

void TaskPack::set_profile(bool on) {
  profile_on_ = on;
  wall_ = tasks::StageProfile{};
  for (auto& e : envs_) e->set_profile(on);
}

tasks::StageProfile TaskPack::profile() const {
  // steps and wall time of the pack's own steps; thread-seconds summed over the entries
  tasks::StageProfile p = wall_;
  for (auto& e : envs_) {
    const tasks::StageProfile q = e->profile();
    p.actions += q.actions;
    p.task += q.task;
  }
  return p;
}

}  // namespace bidex::taskpack
