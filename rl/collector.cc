#include "rl/collector.h"

#include <cstring>

#include "core/clock.h"
#include "core/error.h"
#include "taskpack/pack.h"
#include "taskpack/warp_pack.h"

namespace bidex::rl {

double Collector::take_sim_seconds() {
  const double s = sim_s_;
  sim_s_ = 0;
  return s;
}

namespace {

class HostCollector : public Collector {
 public:
  HostCollector(taskpack::TaskPack& env, const torch::Device& device, bool record)
      : Collector(record), env_(env), device_(device) {
    const int64_t N = env.nslot(), D = env.obs_dim();
    auto host = torch::TensorOptions().dtype(torch::kFloat32).pinned_memory(device.is_cuda());
    // one transfer per step:
    // [obs N*D | reward N | done N | bootstrap slot ids K | their final obs K*D]
    // and in record mode after it [truncated N | every final obs N*D]
    staging_ = torch::empty({(record ? 3 : 2) * N * D + 4 * N}, host);
    const auto on = torch::TensorOptions().device(device);
    no_ids_ = torch::empty({0}, on.dtype(torch::kLong));
    no_final_obs_ = torch::empty({0, D}, on.dtype(torch::kFloat32));
  }

  torch::Tensor reset() override {
    const int N = env_.nslot(), D = env_.obs_dim();
    env_.reset();
    int k = 0;
    return upload(false, &k).narrow(0, 0, int64_t(N) * D).view({N, D});
  }

  Transition step(const torch::Tensor& actions) override {
    const int N = env_.nslot(), D = env_.obs_dim();
    auto host_a = actions.to(torch::kCPU).contiguous();
    const double t0 = monotonic_seconds();
    env_.step(host_a.data_ptr<float>());
    sim_s_ += monotonic_seconds() - t0;
    int k = 0;
    auto dev = upload(true, &k);
    Transition t;
    t.obs = dev.narrow(0, 0, int64_t(N) * D).view({N, D});
    t.reward = dev.narrow(0, int64_t(N) * D, N);
    t.done = dev.narrow(0, int64_t(N) * D + N, N);
    if (k > 0) {  // most steps cut no episode: no conversion then
      t.final_ids = dev.narrow(0, int64_t(N) * D + 2 * N, k).to(torch::kLong);
      t.final_obs = dev.narrow(0, int64_t(N) * D + 2 * N + k, int64_t(k) * D).view({k, D});
    } else {
      t.final_ids = no_ids_;
      t.final_obs = no_final_obs_;
    }
    if (record_) {
      const int64_t at = int64_t(N) * D + 2 * N + k + int64_t(k) * D;
      t.truncated = dev.narrow(0, at, N);
      t.end_obs = dev.narrow(0, at + N, int64_t(N) * D).view({N, D});
    }
    return t;
  }

 private:
  // copies the pack's outputs into the staging buffer and it to the device
  torch::Tensor upload(bool with_final, int* k_out) {
    const int N = env_.nslot(), D = env_.obs_dim();
    float* st = staging_.data_ptr<float>();
    std::memcpy(st, env_.obs.data(), sizeof(float) * N * D);
    float* rew = st + int64_t(N) * D;
    float* done = rew + N;
    float* ids = done + N;
    int k = 0;
    for (int i = 0; i < N; ++i) {
      rew[i] = env_.reward[i];
      done[i] = (env_.terminated[i] || env_.truncated[i]) ? 1.f : 0.f;
      if (with_final && env_.truncated[i] && !env_.fault[i]) ids[k++] = static_cast<float>(i);
    }
    float* fin = ids + k;
    for (int j = 0; j < k; ++j)
      std::memcpy(fin + int64_t(j) * D, env_.final_obs.data() + int64_t(ids[j]) * D,
                  sizeof(float) * D);
    int64_t used = int64_t(N) * D + 2 * N + k + int64_t(k) * D;
    if (record_ && with_final) {
      float* trunc = st + used;
      for (int i = 0; i < N; ++i) trunc[i] = env_.truncated[i] && !env_.fault[i] ? 1.f : 0.f;
      std::memcpy(trunc + N, env_.final_obs.data(), sizeof(float) * N * D);
      used += N + int64_t(N) * D;
    }
    *k_out = k;
    return device_.is_cuda() ? staging_.narrow(0, 0, used).to(device_, /*non_blocking=*/true)
                             : staging_.narrow(0, 0, used).clone();
  }

  taskpack::TaskPack& env_;
  torch::Device device_;
  torch::Tensor staging_;
  torch::Tensor no_ids_, no_final_obs_;  // what a step that cut no episode hands back
};

class DeviceCollector : public Collector {
 public:
  DeviceCollector(taskpack::WarpPack& env, const torch::Device& device, bool record)
      : Collector(record), env_(env), device_(device) {
    if (env.on_gpu() != device.is_cuda())
      throw Error(std::string("the pack steps on ") + (env.on_gpu() ? "the GPU" : "the CPU") +
                  " (" + env.device() + ") but the learner is on " + device.str() +
                  ": a GPU pack's rows are read in place, so both must be on one device");
    const int64_t N = env.nslot(), D = env.obs_dim(), A = env.act_dim();
    const auto on = torch::TensorOptions().dtype(torch::kFloat32).device(device);
    actions_ = torch::from_blob(env.actions(), {N, A}, on);
    obs_ = torch::from_blob(env.obs(), {N, D}, on);
    final_obs_ = torch::from_blob(env.final_obs(), {N, D}, on);
    reward_ = torch::from_blob(env.reward(), {N}, on);
    done_ = torch::from_blob(env.done(), {N}, on);
    bootstrap_ = torch::from_blob(env.bootstrap(), {N}, on);
  }

  torch::Tensor reset() override {
    wait_for_learner();
    env_.reset();
    return obs_.clone();
  }

  Transition step(const torch::Tensor& actions) override {
    actions_.copy_(actions);
    wait_for_learner();  // the actions are written before the pack's streams read them
    const double t0 = monotonic_seconds();
    env_.step();  // returns when every row is written
    sim_s_ += monotonic_seconds() - t0;
    Transition t;
    // copies on the learner's device: the next step overwrites the pack's rows
    t.obs = obs_.clone();
    t.reward = reward_.clone();
    t.done = done_.clone();
    t.final_ids = bootstrap_.nonzero().flatten();
    t.final_obs = final_obs_.index_select(0, t.final_ids);
    if (record_) {
      t.truncated = bootstrap_.clone();
      t.end_obs = final_obs_.clone();
    }
    return t;
  }

 private:
  void wait_for_learner() {
    if (device_.is_cuda()) torch::cuda::synchronize(device_.index());
  }

  taskpack::WarpPack& env_;
  torch::Device device_;
  torch::Tensor actions_, obs_, final_obs_, reward_, done_, bootstrap_;
};

}  // namespace

std::unique_ptr<Collector> make_collector(taskpack::Pack& pack, const torch::Device& device,
                                          bool record) {
  if (auto* cpu = dynamic_cast<taskpack::TaskPack*>(&pack))
    return std::make_unique<HostCollector>(*cpu, device, record);
  if (auto* gpu = dynamic_cast<taskpack::WarpPack*>(&pack))
    return std::make_unique<DeviceCollector>(*gpu, device, record);
  throw Error("collector: a pack of an unknown kind (" + pack.device() + ")");
}

}  // namespace bidex::rl
