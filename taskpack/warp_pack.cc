#include "taskpack/warp_pack.h"

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
  for (int g = 0; g < ngroups(); ++g) {
    const PackEntry& e = spec_.entries[g];
    tasks::WarpEnvOptions o;
    o.nslot = e.slots;
    o.seed = group_seed(options.seed, g);
    o.device = options.device;
    o.hand_file = options.hand_file;
    o.physics_file = options.physics_file;
    envs_.push_back(
        std::make_unique<tasks::WarpTaskEnv>(tasks::make_task(e.task, e.config), o));
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
    b.allocate("pack_keep", obs_pad_, 1, 1);
    b.upload_bytes("pack_keep", keep_[g].data(), keep_[g].size());
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
    r.keep = u8("pack_keep");
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
    for (auto& e : envs_) e->synchronize();
    return;
  }
  for (auto& e : envs_) e->synchronize();
  for (const EntryRows& r : rows_)
    for (int l = 0; l < r.n; ++l) pack_slot(r, l);
}

void WarpPack::reset() {
  for (auto& e : envs_) e->reset();
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
  for (int g = 0; g < ngroups(); ++g)
    envs_[g]->reset_slots(std::vector<uint8_t>(mask + begin_[g], mask + begin_[g] + group_slots(g)));
  write_rows();  // the reset worlds' rows: no reward, no end; the others' as they were
}

void WarpPack::step() {
  const double t0 = monotonic_seconds();
  for (auto& e : envs_) e->step();  // queued on each entry's stream: the scenes overlap
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
  for (auto& e : envs_) n += e->backend().total_faults();
  return n;
}

std::string WarpPack::room_advice() const {
  std::string out;
  for (int g = 0; g < ngroups(); ++g) {
    const std::string a = envs_[g]->backend().room_advice();
    if (!a.empty()) out.append(out.empty() ? "" : "\n").append(label(g)).append(": ").append(a);
  }
  return out;
}

std::vector<WarpPack::Rows> WarpPack::rows() const {
  std::vector<Rows> out;
  for (const auto& e : envs_) out.push_back({e->backend().max_rows(), e->backend().options().njmax});
  return out;
}

void WarpPack::set_profile(bool on) {
  for (auto& e : envs_) e->set_profile(on);
}

tasks::StageProfile WarpPack::profile() const {
  // with the profile on every stage waits, so the entries run one after another and their
  // times add up
  tasks::StageProfile p;
  for (auto& e : envs_) {
    const tasks::StageProfile& q = e->profile();
    p.steps = q.steps;
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
