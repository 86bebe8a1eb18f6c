#include "tasks/warp_env.h"

#include <algorithm>
#include <cstring>

#include "core/clock.h"
#include "core/error.h"
#include "sim/cuda_driver.h"
#include "tasks/gpu_families.h"

namespace bidex::tasks {

namespace {

// The stages as a host loop over Warp's CPU-device arrays (the CUDA runner's kernels run the
// same per-world functions).
template <class B>
class HostRunner : public StageRunner {
 public:
  explicit HostRunner(const typename B::Program& p) : p_(p) {}
  void run(Stage s, const WorldArrays& a, int n) override {
    with_stage(s, [&](auto stage) {
#pragma omp parallel for schedule(static)
      for (int w = 0; w < n; ++w) world_stage<B, decltype(stage)::value>(p_, a, w);
    });
  }

 private:
  typename B::Program p_;
};

std::unique_ptr<StageRunner> make_host_runner(const Task& task) {
#define BIDEX_X(name, Task_)                     \
  if (auto* t = dynamic_cast<const Task_*>(&task))                 \
    return std::make_unique<HostRunner<Task_::Bodies>>(t->program());
  BIDEX_GPU_FAMILIES(BIDEX_X)
#undef BIDEX_X
  return nullptr;
}

std::string gpu_families() {
  std::string s;
#define BIDEX_X(name, Task_) s += std::string(s.empty() ? "" : ", ") + #name;
  BIDEX_GPU_FAMILIES(BIDEX_X)
#undef BIDEX_X
  return s;
}

}  // namespace

bool runs_on_warp(const Task& task) {
#define BIDEX_X(name, Task_) \
  if (dynamic_cast<const Task_*>(&task)) return true;
  BIDEX_GPU_FAMILIES(BIDEX_X)
#undef BIDEX_X
  return false;
}

std::string choose_device(const std::string& requested, const Task& task, std::string* why) {
  auto say = [&](const std::string& s) {
    if (why) *why = s;
  };
  if (requested == "cpu" || requested == "cuda") {
    say("as asked");
    return requested;
  }
  if (requested != "auto")
    throw ConfigError("", "--device", "auto, cpu or cuda", requested);
  if (!sim::warp_built()) {
    say("this build has no GPU backend");
  } else if (!sim::cuda::driver_available()) {
    say("no NVIDIA driver");
  } else if (!runs_on_warp(task)) {
    say(task.spec().id + "'s stages do not run on the GPU yet");
  } else {
    say("a GPU driver and MuJoCo Warp's backend are present");
    return "cuda";
  }
  return "cpu";
}

namespace {

// The checks before a task's scene is built.
void check_env(const Task& task, const WarpEnvOptions& o) {
  if (o.nslot <= 0) throw ConfigError("", "nslot", "a slot count > 0", std::to_string(o.nslot));
  if (!runs_on_warp(task))
    throw Error(task.spec().id + ": its stages do not run on the GPU backend yet (families "
                "there: " + gpu_families() + "); use --device cpu");
}

sim::WarpOptions backend_options(const WarpEnvOptions& o) {
  sim::WarpOptions wo;
  wo.device = o.device;
  return wo;
}

}  // namespace

WarpTaskEnv::WarpTaskEnv(std::unique_ptr<Task> task, const WarpEnvOptions& o)
    : task_(std::move(task)) {
  check_env(*task_, o);
  auto shared = std::make_shared<Shared>();
  shared->models.push_back(build_task_model(*task_, o.hand_file, o.physics_file, /*on_gpu=*/true));
  shared->backend =
      std::make_unique<sim::WarpBackend>(*shared->models[0], o.nslot, backend_options(o));
  join(std::move(shared), 0, 0, o);
}

WarpTaskEnv::WarpTaskEnv(std::unique_ptr<Task> task, std::shared_ptr<Shared> shared, int member,
                         int first, std::string prefix, const WarpEnvOptions& o)
    : task_(std::move(task)), prefix_(std::move(prefix)) {
  join(std::move(shared), member, first, o);
}

std::vector<std::unique_ptr<WarpTaskEnv>> WarpTaskEnv::make_envs(
    std::vector<std::unique_ptr<Task>> tasks, const std::vector<WarpEnvOptions>& options,
    bool share_scenes) {
  if (tasks.size() != options.size())
    throw Error("WarpTaskEnv::make_envs: " + std::to_string(tasks.size()) + " tasks and " +
                std::to_string(options.size()) + " options; expected one per task");
  const size_t n = tasks.size();
  std::vector<std::unique_ptr<sim::SimModel>> models;
  for (size_t k = 0; k < n; ++k) {
    check_env(*tasks[k], options[k]);
    if (options[k].device != options[0].device || options[k].hand_file != options[0].hand_file ||
        options[k].physics_file != options[0].physics_file)
      throw Error("WarpTaskEnv::make_envs: " + tasks[k]->spec().id +
                  "'s device, hand or physics file differs from " + tasks[0]->spec().id + "'s");
    models.push_back(build_task_model(*tasks[k], options[k].hand_file, options[k].physics_file,
                                      /*on_gpu=*/true));
  }
  std::vector<int> group(n);
  for (size_t k = 0; k < n; ++k) group[k] = static_cast<int>(k);
  if (share_scenes && n > 1) {
    std::vector<const sim::SimModel*> scenes;
    for (auto& m : models) scenes.push_back(m.get());
    group = sim::WarpBackend::topology_groups(scenes);
  }
  std::vector<std::unique_ptr<WarpTaskEnv>> out(n);
  for (size_t k = 0; k < n; ++k) {
    if (out[k]) continue;  // built with an earlier task of its group
    std::vector<size_t> members;
    for (size_t j = k; j < n; ++j)
      if (group[j] == group[k]) members.push_back(j);
    auto shared = std::make_shared<Shared>();
    std::vector<const sim::SimModel*> scenes;
    std::vector<int> worlds;
    for (size_t j : members) {
      shared->models.push_back(std::move(models[j]));
      scenes.push_back(shared->models.back().get());
      worlds.push_back(options[j].nslot);
    }
    shared->backend =
        std::make_unique<sim::WarpBackend>(scenes, worlds, backend_options(options[k]));
    int first = 0;
    for (size_t i = 0; i < members.size(); ++i) {
      const size_t j = members[i];
      // its arrays' names: a single env's when alone on its backend
      std::string prefix;  // (GCC 12 warns falsely of "m" + std::to_string(i))
      if (members.size() > 1) prefix.append("m").append(std::to_string(i)).append("/");
      out[j].reset(new WarpTaskEnv(std::move(tasks[j]), shared, static_cast<int>(i), first,
                                   prefix, options[j]));
      first += options[j].nslot;
    }
  }
  return out;
}

void WarpTaskEnv::join(std::shared_ptr<Shared> shared, int member, int first,
                       const WarpEnvOptions& o) {
  shared_ = std::move(shared);
  model_ = shared_->models.at(member).get();
  first_ = first;
  nslot_ = o.nslot;
  sim::WarpBackend& backend = *shared_->backend;
  const TaskSpec& sp = task_->spec();
  runner_ = backend.on_gpu() ? make_cuda_runner(*task_, backend.stream())
                             : make_host_runner(*task_);
  if (!runner_)
    throw DeviceError(sp.id + ": this build has no CUDA kernels for the task stages (configure "
                      "with the CUDA toolkit's nvcc on PATH, BIDEX_CUDA=ON)");

  WorldArrays& a = arrays_;
  a.obs_dim = sp.obs.dim();
  a.act_dim = sp.act.dim();
  a.act_stride = a.act_dim;
  a.nterms = static_cast<int>(sp.reward_terms.size());
  a.episode_length = task_->episode_length();
  a.seed = o.seed;
  a.obs_clip = TaskEnv::kObsClip;
  if (a.nterms > kMaxTerms || a.act_dim > kMaxActions)
    throw Error(sp.id + ": more reward terms or actions than the stages support");

  // the backend's arrays: this env's rows of them
  auto f = [&](const char* name, int* width, int per) {
    const sim::WorldArray w = backend.rows(name, first_, nslot_);
    if (width) *width = w.width / per;
    return reinterpret_cast<float*>(w.ptr);
  };
  a.qpos = f("qpos", &a.nq, 1);
  a.qvel = f("qvel", &a.nv, 1);
  a.qfrc_actuator = f("qfrc_actuator", nullptr, 1);
  a.qfrc_constraint = f("qfrc_constraint", nullptr, 1);
  a.sensordata = f("sensordata", &a.nsensordata, 1);
  a.xpos = f("xpos", &a.nbody, 3);
  a.xquat = f("xquat", nullptr, 1);
  a.cvel = f("cvel", nullptr, 1);
  a.subtree_com = f("subtree_com", nullptr, 1);
  a.ctrl = f("ctrl", &a.nu, 1);
  a.base_wrench = f("base_wrench", &a.nwrench, 1);
  a.mocap_pos = f("mocap_pos", &a.nmocap, 3);
  a.mocap_quat = f("mocap_quat", nullptr, 1);
  a.fault = reinterpret_cast<const uint32_t*>(backend.rows("fault", first_, nslot_).ptr);
  a.reset = reinterpret_cast<int32_t*>(backend.rows("reset", first_, nslot_).ptr);

  // the env's, zeroed, in the backend's memory
  auto alloc = [&](const char* name, int width, size_t elem) {
    const sim::WorldArray w = backend.allocate(own(name), width, elem, nslot_);
    buffers_.push_back({name, {w.ptr, width, elem}});
    return w.ptr;
  };
  a.actions = reinterpret_cast<const float*>(alloc("actions", a.act_dim, sizeof(float)));
  a.state = reinterpret_cast<SlotState*>(alloc("state", 1, sizeof(SlotState)));
  a.rng = reinterpret_cast<SlotRng*>(alloc("rng", 1, sizeof(SlotRng)));
  a.obs = reinterpret_cast<float*>(alloc("obs", a.obs_dim, sizeof(float)));
  a.final_obs = reinterpret_cast<float*>(alloc("final_obs", a.obs_dim, sizeof(float)));
  a.reward = reinterpret_cast<float*>(alloc("reward", 1, sizeof(float)));
  a.terms = reinterpret_cast<float*>(alloc("terms", a.nterms, sizeof(float)));
  a.terminated = reinterpret_cast<uint8_t*>(alloc("terminated", 1, 1));
  a.truncated = reinterpret_cast<uint8_t*>(alloc("truncated", 1, 1));
  a.success = reinterpret_cast<uint8_t*>(alloc("success", 1, 1));
  a.faulted = reinterpret_cast<uint8_t*>(alloc("faulted", 1, 1));
  a.ep_return = reinterpret_cast<double*>(alloc("ep_return", 1, sizeof(double)));
  a.ep_terms = reinterpret_cast<double*>(alloc("ep_terms", a.nterms, sizeof(double)));
  a.done_return = reinterpret_cast<double*>(alloc("done_return", 1, sizeof(double)));
  a.done_length = reinterpret_cast<double*>(alloc("done_length", 1, sizeof(double)));
  a.done_terms = reinterpret_cast<double*>(alloc("done_terms", a.nterms, sizeof(double)));
  a.done_episodes = reinterpret_cast<int64_t*>(alloc("done_episodes", 1, sizeof(int64_t)));
  a.done_successes = reinterpret_cast<int64_t*>(alloc("done_successes", 1, sizeof(int64_t)));
  a.done_terminated = reinterpret_cast<int64_t*>(alloc("done_terminated", 1, sizeof(int64_t)));
  a.done_truncated = reinterpret_cast<int64_t*>(alloc("done_truncated", 1, sizeof(int64_t)));
  a.done_faults = reinterpret_cast<int64_t*>(alloc("done_faults", 1, sizeof(int64_t)));
  a.held = reinterpret_cast<uint8_t*>(alloc("held", 1, 1));

  // per-world random streams keyed like the CPU batch's: (seed, world, episode)
  std::vector<SlotRng> rng(nslot_);
  for (int w = 0; w < nslot_; ++w) rng[w] = SlotRng::make(o.seed, static_cast<uint32_t>(w), 0);
  backend.upload_bytes(own("rng"), rng.data(), rng.size() * sizeof(SlotRng));
  shared_->members.push_back(this);
  reset();
}

WarpTaskEnv::~WarpTaskEnv() {
  if (!shared_) return;
  auto& m = shared_->members;
  m.erase(std::remove(m.begin(), m.end(), this), m.end());
}

bool WarpTaskEnv::owns(const std::string& name) const {
  for (const auto& b : buffers_)
    if (b.first == name) return true;
  return false;
}

sim::WorldArray WarpTaskEnv::array(const std::string& name) const {
  return owns(name) ? backend().array(own(name)) : backend().rows(name, first_, nslot_);
}

int WarpTaskEnv::max_rows() const {
  int m = 0;
  for (int32_t r : download<int32_t>("rows_max")) m = std::max(m, static_cast<int>(r));
  return m;
}

void WarpTaskEnv::copy(const std::string& name, void* dst, size_t bytes) const {
  for (const auto& [n, b] : buffers_)
    if (n == name && bytes != static_cast<size_t>(nslot_) * b.width * b.elem)
      throw Error("WarpTaskEnv: '" + name + "' holds " + std::to_string(b.elem) +
                  "-byte values; asked for another size");
  if (owns(name))
    backend().download_bytes(own(name), dst, bytes);
  else
    backend().download_bytes(name, dst, bytes, first_);
}

std::vector<SlotState> WarpTaskEnv::slot_states() const {
  std::vector<SlotState> st(nslot_);
  copy("state", st.data(), st.size() * sizeof(SlotState));
  return st;
}

template <class F>
void WarpTaskEnv::edit_slot_states(F&& edit) {
  synchronize();
  std::vector<SlotState> st = slot_states();
  edit(st.data());  // throws before the upload: then no state has changed
  backend().upload_bytes(own("state"), st.data(), st.size() * sizeof(SlotState));
}

void WarpTaskEnv::set_goal_shifts(const std::vector<int>& slots,
                                  const std::vector<double>& shifts) {
  edit_slot_states(
      [&](SlotState* st) { tasks::set_goal_shifts(spec(), st, nslot_, slots, shifts); });
}

void WarpTaskEnv::set_levels(double level) {
  edit_slot_states([&](SlotState* st) { tasks::set_levels(*task_, st, nslot_, level); });
}

void WarpTaskEnv::reset() {
  reset_slots(std::vector<uint8_t>(nslot_, 1));
}

void WarpTaskEnv::reset_slots(const std::vector<uint8_t>& mask) {
  if (mask.size() != static_cast<size_t>(nslot_))
    throw Error(spec().id + ": reset_slots expects " + std::to_string(nslot_) +
                " mask values, got " + std::to_string(mask.size()));
  reset_worlds({this}, {mask.data()});
}

void WarpTaskEnv::reset_worlds(const std::vector<WarpTaskEnv*>& envs,
                               const std::vector<const uint8_t*>& masks) {
  if (envs.empty()) return;
  if (masks.size() != envs.size())
    throw Error("WarpTaskEnv::reset_worlds: " + std::to_string(envs.size()) + " envs and " +
                std::to_string(masks.size()) + " masks");
  sim::WarpBackend& backend = envs[0]->backend();
  // the backend's reset pass restarts every marked world: the others' marks are cleared
  std::vector<int32_t> marked(static_cast<size_t>(backend.nworld()), 0);
  for (size_t i = 0; i < envs.size(); ++i) {
    const WarpTaskEnv& e = *envs[i];
    if (e.shared_ != envs[0]->shared_)
      throw Error("WarpTaskEnv::reset_worlds: " + e.spec().id + " and " + envs[0]->spec().id +
                  " are not on one backend");
    for (int l = 0; l < e.nslot_; ++l) marked[e.first_ + l] = masks[i][l];
  }
  backend.upload_bytes("reset", marked.data(), marked.size() * sizeof(int32_t));
  backend.reset_begin();
  for (WarpTaskEnv* e : envs) {
    e->arrays_.clearing = 1;
    e->runner_->run(Stage::kReset, e->arrays_, e->nslot_);
    e->arrays_.clearing = 0;
  }
  backend.reset_end();
  for (WarpTaskEnv* e : envs) e->runner_->run(Stage::kObserve, e->arrays_, e->nslot_);
}

void WarpTaskEnv::step() {
  // every member's stage, then the backend's pass, in the order one env alone runs them
  sim::WarpBackend& backend = this->backend();
  const std::vector<WarpTaskEnv*>& group = shared_->members;
  auto stage = [&](Stage s) {
    for (WarpTaskEnv* e : group) e->runner_->run(s, e->arrays_, e->nslot_);
  };
  const double t0 = profile_on_ ? monotonic_seconds() : 0;
  stage(Stage::kApply);
  double t1 = 0, t2 = 0;
  if (profile_on_) {
    backend.synchronize();
    t1 = monotonic_seconds();
  }
  backend.step();
  if (profile_on_) {
    backend.synchronize();
    t2 = monotonic_seconds();
  }
  stage(Stage::kEvaluate);
  backend.reset_begin();
  stage(Stage::kReset);
  backend.reset_end();
  stage(Stage::kObserve);
  if (profile_on_) {  // the group's times, in the env that stepped it
    backend.synchronize();
    const double t3 = monotonic_seconds();
    profile_.steps += 1;
    profile_.actions += t1 - t0;
    profile_.task += t3 - t2;
    profile_.wall += t3 - t0;
  }
}

void WarpTaskEnv::set_actions(const float* actions, int stride) {
  if (stride < arrays_.act_dim)
    throw Error(spec().id + ": an action row of " + std::to_string(stride) +
                " values is narrower than the task's " + std::to_string(arrays_.act_dim));
  arrays_.actions = actions;
  arrays_.act_stride = stride;
}

void WarpTaskEnv::synchronize() { backend().synchronize(); }

void WarpTaskEnv::set_profile(bool on) {
  profile_on_ = on;
  profile_ = StageProfile{};
}

void WarpTaskEnv::step(const std::vector<float>& actions) {
  const size_t n = static_cast<size_t>(nslot_) * arrays_.act_dim;
  if (actions.size() != n)
    throw Error(spec().id + ": step expects " + std::to_string(nslot_) + " x " +
                std::to_string(arrays_.act_dim) + " actions, got " +
                std::to_string(actions.size()));
  backend().upload_bytes(own("actions"), actions.data(), n * sizeof(float));
  set_actions(reinterpret_cast<const float*>(array("actions").ptr), arrays_.act_dim);
  step();
}

EpisodeStats WarpTaskEnv::take_stats() {
  EpisodeStats st;
  const auto ret = download<double>("done_return");
  const auto len = download<double>("done_length");
  const auto terms = download<double>("done_terms");
  const auto eps = download<int64_t>("done_episodes");
  const auto suc = download<int64_t>("done_successes");
  const auto term = download<int64_t>("done_terminated");
  const auto trunc = download<int64_t>("done_truncated");
  const auto faults = download<int64_t>("done_faults");
  st.term_sums.assign(arrays_.nterms, 0.0);
  for (int w = 0; w < nslot_; ++w) {
    st.episodes += eps[w];
    st.successes += suc[w];
    st.terminated += term[w];
    st.truncated += trunc[w];
    st.faults += faults[w];
    st.return_sum += ret[w];
    st.length_sum += len[w];
    for (int k = 0; k < arrays_.nterms; ++k) st.term_sums[k] += terms[w * arrays_.nterms + k];
  }
  if (task_->curriculum()) {  // the levels live in the slot states (once an update)
    const std::vector<SlotState> states = slot_states();
    add_levels(st, states.data(), nslot_);
  }
  for (const char* name : {"done_return", "done_length", "done_terms", "done_episodes",
                           "done_successes", "done_terminated", "done_truncated",
                           "done_faults"}) {
    for (const auto& [n, b] : buffers_) {
      if (n != name) continue;
      std::vector<uint8_t> zero(static_cast<size_t>(nslot_) * b.width * b.elem, 0);
      backend().upload_bytes(own(name), zero.data(), zero.size());
    }
  }
  return st;
}

#ifndef BIDEX_HAS_CUDA
std::unique_ptr<StageRunner> make_cuda_runner(const Task&, uintptr_t) { return nullptr; }
#endif

}  // namespace bidex::tasks
