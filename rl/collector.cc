#include "rl/collector.h"

#include <cstring>

#include "core/clock.h"
#include "taskpack/pack.h"

namespace bidex::rl {

Collector::Collector(taskpack::TaskPack& env, const torch::Device& device)
    : env_(env), device_(device) {
  const int64_t N = env.nslot(), D = env.obs_dim();
  auto host = torch::TensorOptions().dtype(torch::kFloat32).pinned_memory(device.is_cuda());
  // one transfer per step:
  // [obs N*D | reward N | done N | bootstrap slot ids K | their final obs K*D]
  staging_ = torch::empty({2 * N * D + 3 * N}, host);
  const auto on = torch::TensorOptions().device(device);
  no_ids_ = torch::empty({0}, on.dtype(torch::kLong));
  no_final_obs_ = torch::empty({0, D}, on.dtype(torch::kFloat32));
}

torch::Tensor Collector::upload(bool with_final, int* k_out) {
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
  const int64_t used = int64_t(N) * D + 2 * N + k + int64_t(k) * D;
  *k_out = k;
  return device_.is_cuda() ? staging_.narrow(0, 0, used).to(device_, /*non_blocking=*/true)
                           : staging_.narrow(0, 0, used).clone();
}

torch::Tensor Collector::reset() {
  const int N = env_.nslot(), D = env_.obs_dim();
  env_.reset();
  int k = 0;
  return upload(false, &k).narrow(0, 0, int64_t(N) * D).view({N, D});
}

Transition Collector::step(const torch::Tensor& actions) {
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
  return t;
}

double Collector::take_sim_seconds() {
  const double s = sim_s_;
  sim_s_ = 0;
  return s;
}

}  // namespace bidex::rl
