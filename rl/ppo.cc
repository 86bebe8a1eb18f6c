#include "rl/ppo.h"

#include <algorithm>
#include <cstdio>
#include <string>

#include "rl/autocast.h"
#include "rl/checkpoint.h"
#include "rl/onpolicy.h"
#include "rl/suite_tasks.h"

#ifdef BIDEX_TORCH_CUDA
#include <ATen/cuda/CUDAEvent.h>
#include <ATen/cuda/CUDAGraph.h>
#include <c10/cuda/CUDAGuard.h>
#include <c10/cuda/CUDAStream.h>

#include "rl/cuda_graph.h"
#endif

namespace bidex::rl {

Rollout::Rollout(int64_t T, int64_t N, int64_t D, int64_t A, const torch::Device& device)
    : horizon(T), nslot(N) {
  auto f = torch::TensorOptions().dtype(torch::kFloat32).device(device);
  nobs = torch::zeros({T, N, D}, f);
  actions = torch::zeros({T, N, A}, f);
  logp = torch::zeros({T, N}, f);
  mu = torch::zeros({T, N, A}, f);
  values = torch::zeros({T, N}, f);
  rewards = torch::zeros({T, N}, f);
  dones = torch::zeros({T, N}, f);
  log_std = torch::zeros({A}, f);
}

torch::Tensor clipped_surrogate(const torch::Tensor& ratio, const torch::Tensor& advantages,
                                double clip) {
  auto clipped = torch::clamp(ratio, 1.0 - clip, 1.0 + clip);
  return -torch::min(ratio * advantages, clipped * advantages).mean();
}

std::pair<torch::Tensor, torch::Tensor> gae(const torch::Tensor& rewards,
                                            const torch::Tensor& values,
                                            const torch::Tensor& dones,
                                            const torch::Tensor& last_value, double gamma,
                                            double lambda) {
  torch::NoGradGuard ng;
  const int64_t T = rewards.size(0);
  auto adv = torch::zeros_like(rewards);
  auto running = torch::zeros_like(last_value);
  for (int64_t t = T - 1; t >= 0; --t) {
    auto next_value = t == T - 1 ? last_value : values[t + 1];
    auto alive = 1.0 - dones[t];
    auto delta = rewards[t] + gamma * next_value * alive - values[t];
    running = delta + gamma * lambda * alive * running;
    adv[t] = running;
  }
  return {adv, adv + values};
}

torch::Tensor normalize_advantages(const torch::Tensor& adv, const torch::Tensor& groups,
                                   int64_t ngroups) {
  torch::NoGradGuard ng;
  if (!groups.defined()) return (adv - adv.mean()) / (adv.std() + 1e-8);
  // the sample deviation per group, as adv.std() over the whole update
  const auto m = group_moments(adv, groups, ngroups);
  const auto std = (m.sq_dev / (m.count - 1).clamp_min(1)).sqrt();
  return m.dev / (std.index_select(0, groups) + 1e-8);
}

void adapt_lr(const torch::Tensor& lr, const torch::Tensor& kl, double desired_kl) {
  torch::NoGradGuard ng;
  const auto k = kl.to(torch::kFloat64);  // compared in double, as a host read of it would be
  const auto lower = torch::clamp_min(lr / 1.5, 1e-5);
  const auto higher = torch::clamp_max(lr * 1.5, 1e-2);
  const auto small = torch::logical_and(k < 0.5 * desired_kl, k > 0.0);
  lr.copy_(torch::where(k > 2.0 * desired_kl, lower, torch::where(small, higher, lr)));
}

#ifdef BIDEX_TORCH_CUDA
// The minibatch step as a CUDA graph: captured once from the second update on (the first runs
// eagerly on the same side stream: cuBLAS's workspace for that stream and the autograd engine's
// threads exist before the capture, as CUDA graphs need), then replayed for every minibatch.
// The graph reads the update's rows from buffers that keep their addresses (`rows`: the
// rollout's own tensors, and copies of the advantages, targets and old values) and the
// minibatch's row numbers from `idx`.
struct Ppo::Graph {
  c10::cuda::CUDAStream stream = c10::cuda::getStreamFromPool();
  std::unique_ptr<at::cuda::CUDAGraph> graph;
  Rows rows;
  torch::Tensor idx;
  bool warm = false;

  // the rollout's tensors moved or changed size: capture again
  bool fits(const Rows& r) const {
    auto same = [](const torch::Tensor& a, const torch::Tensor& b) {
      return a.defined() && a.data_ptr() == b.data_ptr() && a.sizes() == b.sizes();
    };
    return same(rows.nobs, r.nobs) && same(rows.actions, r.actions) &&
           same(rows.logp_old, r.logp_old) && same(rows.mu_old, r.mu_old) &&
           same(rows.log_std_old, r.log_std_old) && rows.advantages.sizes() == r.advantages.sizes();
  }
};
#else
struct Ppo::Graph {};
#endif

Ppo::Ppo(ActorCritic model, const PpoConfig& config, int64_t ntasks)
    : model_(std::move(model)),
      c_(config),
      ntasks_(ntasks),
      opt_(model_->parameters(), c_.lr, 0.9, 0.999, 1e-8, c_.fused_adam) {
  // bfloat16 products read their weights from one copy that each step refreshes
  if (c_.bf16 && c_.bias_grad_gemm) opt_.keep_copy(torch::kBFloat16);
}

Ppo::~Ppo() = default;

void Ppo::minibatch(const Rows& r, const torch::Tensor& idx, bool timed) {
  auto mark = [&](const char* stage) {
    if (timed) timer_.mark(stage);
  };
  auto o = r.nobs.index_select(0, idx);
  auto a = r.actions.index_select(0, idx);
  torch::Tensor mu, v;
  FlatAdam::CopyScope copies(opt_);
  {
    Bf16Autocast bf16(o.device().type(), c_.bf16);  // the networks only; the losses in float32
    mu = model_->mean(o).to(torch::kFloat32);
    v = model_->raw_value(o).to(torch::kFloat32);
  }
  auto log_std = model_->log_std();
  auto logp = gaussian_log_prob(a, mu, log_std);
  mark("forward");
  torch::Tensor kl;
  {
    torch::NoGradGuard ng;
    kl = gaussian_kl(r.mu_old.index_select(0, idx), r.log_std_old, mu, log_std).mean();
  }
  if (c_.schedule == "adaptive") adapt_lr(opt_.lr_tensor(), kl, c_.desired_kl);
  mark("kl_check");
  auto adv_mb = r.advantages.index_select(0, idx);
  auto ratio = torch::exp(logp - r.logp_old.index_select(0, idx));
  auto policy_loss = clipped_surrogate(ratio, adv_mb, c_.clip);
  auto tgt = r.targets.index_select(0, idx);
  torch::Tensor value_loss;
  if (c_.clip_value_loss) {
    auto v_old = r.values_old.index_select(0, idx);
    auto v_clipped = v_old + torch::clamp(v - v_old, -c_.value_clip, c_.value_clip);
    value_loss = torch::max((v - tgt).pow(2), (v_clipped - tgt).pow(2)).mean();
  } else {
    value_loss = (v - tgt).pow(2).mean();
  }
  auto entropy = gaussian_entropy(log_std);
  auto loss = policy_loss + c_.value_coef * value_loss - c_.entropy_coef * entropy;
  mark("forward");
  opt_.zero_grad();
  loss.backward();
  mark("backward");
  opt_.clip_grad_norm(c_.max_grad_norm);
  mark("clip_grad");
  opt_.step();
  mark("optimizer");
  {
    torch::NoGradGuard ng;
    auto clipped = ((ratio - 1.0).abs() > c_.clip).to(torch::kFloat32).mean();
    sums_ += torch::stack({policy_loss, value_loss, entropy, clipped, kl}).to(torch::kFloat64);
  }
  mark("stats");
}

void Ppo::epochs(const Rows& rows, int64_t B, [[maybe_unused]] const torch::Tensor* idx_buffer) {
  const int64_t mb = B / c_.minibatches;
  const auto device = rows.nobs.device();
  for (int epoch = 0; epoch < c_.epochs; ++epoch) {
    auto perm = torch::randperm(B, torch::TensorOptions().dtype(torch::kLong).device(device));
    for (int k = 0; k < c_.minibatches; ++k) {
      auto idx = perm.narrow(0, k * mb, mb);
#ifdef BIDEX_TORCH_CUDA
      if (idx_buffer) {
        idx_buffer->copy_(idx);
        if (graph_->graph) {
          graph_->graph->replay();
          timer_.mark("graph_step");
          continue;
        }
        idx = *idx_buffer;
      }
#endif
      minibatch(rows, idx, true);
    }
  }
}

UpdateStats Ppo::update(const Rollout& r, const torch::Tensor& last_value) {
  timer_.start();
  auto [adv, ret] = gae(r.rewards, r.values, r.dones, last_value, c_.gamma, c_.lambda);
  timer_.mark("gae");
  const int64_t B = r.horizon * r.nslot;
  auto values_old = r.values.reshape({B});
  auto returns = ret.reshape({B});
  auto advantages = adv.reshape({B});
  Rows rows{r.nobs.reshape({B, -1}), r.actions.reshape({B, -1}), r.logp.reshape({B}),
            r.mu.reshape({B, -1}),   r.log_std.detach(),           {}, returns, values_old};
  // each row's task, once, where the advantages or the returns are normalised per task
  const auto tasks = ntasks_ > 0 ? task_ids(rows.nobs, ntasks_) : torch::Tensor();
  rows.advantages = c_.advantage_norm == "task" ? normalize_advantages(advantages, tasks, ntasks_)
                                                : normalize_advantages(advantages);
  if (model_->uses_value_norm()) {
    const auto groups = c_.value_norm_task ? tasks : torch::Tensor();
    auto& vn = model_->value_norm();
    vn->update(returns, groups);
    torch::NoGradGuard ng;
    rows.targets = vn->normalize(returns, groups);
    rows.values_old = vn->normalize(values_old, groups);
  }
  if (c_.bf16) rows.nobs = bf16_input(rows.nobs);
  opt_.rebind();  // the weights' copy as the parameters are now, however they were written
  opt_.refresh_copy();
  timer_.mark("prepare");
  const auto device = rows.nobs.device();
  // policy loss, value loss, entropy, clip fraction, KL: summed on the device, read once at the
  // end with the learning rate
  if (!sums_.defined() || sums_.device() != device)
    sums_ = torch::zeros({5}, torch::TensorOptions().dtype(torch::kFloat64).device(device));
  sums_.zero_();
  bool eager = true;
#ifdef BIDEX_TORCH_CUDA
  if (c_.cuda_graph && device.is_cuda()) {
    eager = false;
    graphed_epochs(rows, B);
  }
#endif
  if (eager) epochs(rows, B, nullptr);
  const int n = c_.epochs * c_.minibatches;
  const auto read =
      torch::cat({sums_ / std::max(n, 1), opt_.lr_tensor().reshape({1})}).to(torch::kCPU);
  timer_.count_syncs(1);  // the statistics and the learning rate, once
  const auto m = read.accessor<double, 1>();
  UpdateStats st;
  st.policy_loss = m[0];
  st.value_loss = m[1];
  st.entropy = m[2];
  st.clip_fraction = m[3];
  st.kl = m[4];
  st.lr = m[5];
  timer_.mark("read_stats");
  return st;
}

const torch::Tensor& Ppo::bf16_input(const torch::Tensor& nobs) {
  torch::NoGradGuard ng;
  const int64_t B = nobs.size(0), width = model_->input_width();
  if (!obs_bf16_.defined() || obs_bf16_.size(0) != B || obs_bf16_.size(1) != width ||
      obs_bf16_.device() != nobs.device())
    obs_bf16_ = torch::zeros({B, width}, nobs.options().dtype(torch::kBFloat16));
  obs_bf16_.narrow(1, 0, nobs.size(1)).copy_(nobs);  // the padding columns stay zero
  return obs_bf16_;
}

#ifdef BIDEX_TORCH_CUDA
void Ppo::graphed_epochs(const Rows& rows, int64_t B) {
  if (!graph_) graph_ = std::make_unique<Graph>();
  Graph& g = *graph_;
  if (!g.fits(rows)) {  // (re)bind the graph's inputs; capture after one more eager update
    g.graph.reset();
    g.warm = false;
    g.rows = rows;
    g.rows.advantages = torch::empty_like(rows.advantages);
    g.rows.targets = torch::empty_like(rows.targets);
    g.rows.values_old = torch::empty_like(rows.values_old);
    g.idx = torch::empty({B / c_.minibatches}, rows.nobs.options().dtype(torch::kLong));
  }
  opt_.rebind();  // a replay runs no host code: the parameters must be the flat buffer's now
  const auto main = c10::cuda::getCurrentCUDAStream();
  at::cuda::CUDAEvent ready;
  ready.record(main);
  ready.block(g.stream);
  {
    c10::cuda::CUDAStreamGuard on_side(g.stream);
    g.rows.advantages.copy_(rows.advantages);
    g.rows.targets.copy_(rows.targets);
    g.rows.values_old.copy_(rows.values_old);
    if (g.warm && !g.graph) {
      g.graph = capture_cuda_graph(
          g.stream, [&] { minibatch(g.rows, g.idx, false); }, "PPO's minibatch step",
          "ppo.cuda_graph");
      if (!g.graph) c_.cuda_graph = false;
    }
    epochs(g.rows, B, c_.cuda_graph ? &g.idx : nullptr);
    g.warm = true;
  }
  at::cuda::CUDAEvent done;
  done.record(g.stream);
  done.block(main);
}
#endif

}  // namespace bidex::rl

namespace bidex::rl {

namespace {

class PpoAlgorithm final : public GaussianOnPolicy {
 public:
  PpoAlgorithm(const TrainConfig& config, int64_t D, int64_t A, int64_t N,
               const torch::Device& device, int64_t ntasks)
      : GaussianOnPolicy(config.ppo, D, A, N, device, config.ppo.value_norm_task ? ntasks : 0) {
    ppo_ = std::make_unique<Ppo>(model_, c_, ntasks);
  }

  std::vector<double> update(const torch::Tensor& obs) override {
    const torch::Tensor last_value = finish_rollout(obs);
    const UpdateStats us = ppo_->update(*ro_, last_value);
    return {us.policy_loss, us.value_loss, us.entropy, us.kl, us.lr, us.clip_fraction,
            action_std()};
  }

  const std::vector<std::string>& metric_names() const override {
    static const std::vector<std::string> names = {"policy_loss", "value_loss", "entropy", "kl",
                                                   "lr",          "clip_fraction", "action_std"};
    return names;
  }

  void enable_profile() override { ppo_->timer().enable(ro_->nobs.device()); }
  std::map<std::string, double> learner_profile() const override {
    return ppo_->timer().totals();
  }

  void save(torch::serialize::OutputArchive& root) override {
    write_part(root, "model", *model_);
    write_part(root, "optimizer", ppo_->optimizer());  // its learning rate included
  }

  void load(torch::serialize::InputArchive& root, const std::string& path) override {
    read_checked(path, "does not fit this run's networks", [&] {
      read_module(root, "model", *model_, path, "this run's networks");
      read_optimizer(root, "optimizer", ppo_->optimizer());
    });
  }

 private:
  std::unique_ptr<Ppo> ppo_;
};

}  // namespace

std::unique_ptr<Algorithm> make_ppo(const TrainConfig& config, int64_t obs_dim, int64_t act_dim,
                                    int64_t nslot, const torch::Device& device) {
  const int64_t ntasks =
      config.ppo.advantage_norm == "task" || config.ppo.value_norm_task
          ? suite_task_count(config, obs_dim, "mtppo: ppo.advantage_norm or value_norm task")
          : 0;
  return std::make_unique<PpoAlgorithm>(config, obs_dim, act_dim, nslot, device, ntasks);
}

}  // namespace bidex::rl
