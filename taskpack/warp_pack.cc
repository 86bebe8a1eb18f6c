#include "taskpack/warp_pack.h"

#include <algorithm>

#include "core/clock.h"
#include "core/error.h"
#include "tasks/registry.h"

namespace bidex::taskpack {

std::string choose_pack_device(const std::string& requested, const PackSpec& spec,
                               std::string* why) {
  if (requested == "cpu" || requested == "cuda") {
    if (why) *why = "as asked";
    return requested;
  }
  if (requested != "auto") throw ConfigError("", "--device", "auto, cpu or cuda", requested);
  std::string reason = "an empty pack", d = "cpu";
  for (const PackEntry& e : spec.entries) {
    std::unique_ptr<tasks::Task> task;
    try {
      task = tasks::make_task(e.task, e.config);
    } catch (const ConfigError&) {
      d = "cpu";  // the pack names the bad entry when it is built
      break;
    }
    d = tasks::choose_device(requested, *task, &reason);
    if (d != "cuda") break;  // one entry that cannot run there keeps the pack on the CPU
  }
  if (why) *why = reason;
  return d;
}

WarpPack::WarpPack(const PackSpec& spec, const WarpPackOptions& options)
    : Pack(spec), options_(options) {
  std::vector<std::unique_ptr<tasks::Task>> tasks;
  std::vector<tasks::WarpEnvOptions> env_options;
  for (int g = 0; g < ngroups(); ++g) {
    const PackEntry& e = spec_.entries[g];
    tasks::WarpEnvOptions o;
    o.nslot = e.slots;
    o.seed = group_seed(options.seed, g);
    o.device = options.device;
    o.hand_file = options.hand_file;
    o.physics_file = options.physics_file;
    tasks.push_back(tasks::make_task(e.task, e.config));
    env_options.push_back(o);
  }
  envs_ = tasks::WarpTaskEnv::make_envs(std::move(tasks), env_options, options.share_scenes);
  for (int g = 0; g < ngroups(); ++g) {
    const auto& members = envs_[g]->group();
    if (members.front() != envs_[g].get()) continue;  // listed with its group's first entry
    std::vector<int> entries;
    for (const tasks::WarpTaskEnv* m : members)
      for (int h = 0; h < ngroups(); ++h)
        if (envs_[h].get() == m) entries.push_back(h);
    backends_.push_back(entries);
  }
  assign_goals();
  for (int g = 0; g < ngroups(); ++g)
    if (!spec_.entries[g].goals.empty()) envs_[g]->reset();  // the first episodes take them
  // the pack's rows live beside entry 0's worlds (one device, one context)
  sim::WarpBackend& home = envs_[0]->backend();
  auto rows = [&](const char* name, int width) {
    return home.allocate(std::string("pack_") + name, width, sizeof(float), nslot_).ptr;
  };
  actions_ = rows("actions", act_dim_);
  obs_ = rows("obs", obs_dim_);
  final_obs_ = rows("final_obs", obs_dim_);
  reward_ = rows("reward", 1);
  done_ = rows("done", 1);
  bootstrap_ = rows("bootstrap", 1);

  for (int g = 0; g < ngroups(); ++g) {
    tasks::WarpTaskEnv& env = *envs_[g];
    sim::WarpBackend& b = env.backend();
    // each entry reads its rows of the padded action matrix in place
    env.set_actions(actions() + static_cast<size_t>(begin_[g]) * act_dim_, act_dim_);
    const std::string keep = "pack_keep/" + std::to_string(g);  // entries may share a backend
    const uintptr_t keep_ptr = b.allocate(keep, obs_pad_, 1, 1).ptr;
    b.upload_bytes(keep, keep_[g].data(), keep_[g].size());
    EntryRows r;
    auto u8 = [&](const char* name) {
      return reinterpret_cast<const uint8_t*>(env.array(name).ptr);
    };
    r.obs = reinterpret_cast<const float*>(env.array("obs").ptr);
    r.final_obs = reinterpret_cast<const float*>(env.array("final_obs").ptr);
    r.reward = reinterpret_cast<const float*>(env.array("reward").ptr);
    r.terminated = u8("terminated");
    r.truncated = u8("truncated");
    r.faulted = u8("faulted");
    r.keep = reinterpret_cast<const uint8_t*>(keep_ptr);
    r.task_obs_dim = env.obs_dim();
    r.n = env.nslot();
    r.begin = begin_[g];
    r.hot = hot_column(g);
    r.scale = spec_.entries[g].reward_scale;
    r.pad = obs_pad_;
    r.width = obs_dim_;
    r.pack_obs = obs();
    r.pack_final_obs = final_obs();
    r.pack_reward = reward();
    r.pack_done = done();
    r.pack_bootstrap = bootstrap();
    rows_.push_back(r);
  }
  write_reset_rows();  // each entry started its episodes when it was built
}

WarpPack::~WarpPack() = default;

bool WarpPack::on_gpu() const { return envs_[0]->on_gpu(); }

void WarpPack::write_rows() {
  if (on_gpu()) {
    for (int g = 0; g < ngroups(); ++g)
      if (!launch_entry_rows(rows_[g], envs_[g]->backend().stream()))
        throw DeviceError("GPU pack: this build has no CUDA kernels (configure with the CUDA "
                          "toolkit's nvcc on PATH, BIDEX_CUDA=ON)");
    synchronize_backends();
    return;
  }
  synchronize_backends();
  for (const EntryRows& r : rows_)
    for (int l = 0; l < r.n; ++l) pack_slot(r, l);
}

// The entries of backend `k`'s envs and masks from `mask` (nslot_ values, or all ones).
void WarpPack::reset_backend(size_t k, const uint8_t* mask) {
  std::vector<tasks::WarpTaskEnv*> envs;
  std::vector<const uint8_t*> masks;
  std::vector<uint8_t> ones;
  if (!mask) {
    ones.assign(static_cast<size_t>(nslot_), 1);
    mask = ones.data();
  }
  for (int g : backends_[k]) {
    envs.push_back(envs_[g].get());
    masks.push_back(mask + begin_[g]);
  }
  tasks::WarpTaskEnv::reset_worlds(envs, masks);
}

// One wait per backend, not per entry: entries that share a backend share its stream.
void WarpPack::synchronize_backends() {
  for (const auto& entries : backends_) envs_[entries.front()]->synchronize();
}

void WarpPack::reset() {
  for (size_t k = 0; k < backends_.size(); ++k) reset_backend(k, nullptr);
  write_reset_rows();
}

void WarpPack::write_reset_rows() {
  write_rows();
  // no step has ended an episode yet
  const std::vector<float> zero(static_cast<size_t>(nslot_), 0.f);
  sim::WarpBackend& home = envs_[0]->backend();
  for (const char* name : {"pack_reward", "pack_done", "pack_bootstrap"})
    home.upload_bytes(name, zero.data(), zero.size() * sizeof(float));
}

void WarpPack::set_autoreset(bool on) {
  for (auto& e : envs_) e->set_autoreset(on);
}

void WarpPack::reset_slots(const uint8_t* mask) {
  for (size_t k = 0; k < backends_.size(); ++k) reset_backend(k, mask);
  write_rows();  // the reset worlds' rows: no reward, no end; the others' as they were
}

void WarpPack::step() {
  const double t0 = monotonic_seconds();
  // each backend's step (its entries' stages and one physics pass) queued on its stream: the
  // backends overlap
  for (const auto& entries : backends_) envs_[entries.front()]->step();
  ++steps_;
  launch_seconds_ += monotonic_seconds() - t0;
  write_rows();
}

void WarpPack::step(const std::vector<float>& actions) {
  const size_t n = static_cast<size_t>(nslot_) * act_dim_;
  if (actions.size() != n)
    throw Error(spec_.name + ": step expects " + std::to_string(nslot_) + " x " +
                std::to_string(act_dim_) + " actions, got " + std::to_string(actions.size()));
  envs_[0]->backend().upload_bytes("pack_actions", actions.data(), n * sizeof(float));
  step();
}

std::vector<float> WarpPack::download(const std::string& name) const {
  const sim::WorldArray a = envs_[0]->backend().array("pack_" + name);
  std::vector<float> out(static_cast<size_t>(a.rows) * a.width);
  envs_[0]->backend().download_bytes("pack_" + name, out.data(), out.size() * sizeof(float));
  return out;
}

std::vector<tasks::EpisodeStats> WarpPack::take_stats() {
  std::vector<tasks::EpisodeStats> out;
  for (auto& e : envs_) out.push_back(e->take_stats());
  return out;
}

int64_t WarpPack::total_faults() const {
  int64_t n = 0;
  for (const auto& entries : backends_) n += envs_[entries.front()]->backend().total_faults();
  return n;
}

std::string WarpPack::room_advice() const {
  std::string out;
  for (const auto& entries : backends_) {
    const std::string a = envs_[entries.front()]->backend().room_advice();
    if (a.empty()) continue;
    std::string labels;
    for (int g : entries) labels.append(labels.empty() ? "" : ", ").append(label(g));
    out.append(out.empty() ? "" : "\n").append(labels).append(": ").append(a);
  }
  return out;
}

Pack::LoadSums WarpPack::load_sums() const {
  LoadSums sums;
  for (const auto& entries : backends_) {
    const sim::WarpBackend& b = envs_[entries.front()]->backend();
    for (int64_t r : b.download_as<int64_t>("efc_rows")) sums.rows += r;
    for (int64_t i : b.download_as<int64_t>("solver_iters")) sums.iterations += i;
  }
  sums.slot_steps = steps_ * nslot_;
  return sums;
}

std::vector<WarpPack::Rows> WarpPack::rows() const {
  std::vector<Rows> out;
  for (const auto& e : envs_) out.push_back({e->max_rows(), e->backend().options().njmax});
  return out;
}

void WarpPack::set_profile(bool on) {
  for (auto& e : envs_) e->set_profile(on);
}

tasks::StageProfile WarpPack::profile() const {
  // with the profile on every stage waits, so the entries run one after another and their
  // times add up
  // (an entry that shares a backend has its group's times in the group's first entry)
  tasks::StageProfile p;
  for (auto& e : envs_) {
    const tasks::StageProfile& q = e->profile();
    p.steps = std::max(p.steps, q.steps);
    p.wall += q.wall;
    p.actions += q.actions;
    p.task += q.task;
  }
  return p;
}

#ifndef BIDEX_HAS_CUDA
bool launch_entry_rows(const EntryRows&, uintptr_t) { return false; }
#endif

}  // namespace bidex::taskpack
