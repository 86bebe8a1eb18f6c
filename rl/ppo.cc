#include "rl/ppo.h"

#include <algorithm>
#include <cstdio>
#include <optional>
#include <stdexcept>
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

void Rollout::copy_from(const Rollout& o) {
  torch::NoGradGuard ng;
  for (auto [to, from] : {std::pair{&nobs, &o.nobs}, {&actions, &o.actions}, {&logp, &o.logp},
                          {&mu, &o.mu}, {&values, &o.values}, {&rewards, &o.rewards},
                          {&dones, &o.dones}, {&log_std, &o.log_std}})
    to->copy_(*from);
}

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
    : model_(std::move(model)), c_(config), ntasks_(ntasks), opt_(model_->parameters(), c_.lr) {}

Ppo::~Ppo() = default;

void Ppo::minibatch(const Rows& r, const torch::Tensor& idx, bool timed) {
  auto mark = [&](const char* stage) {
    if (timed) timer_.mark(stage);
  };
  auto o = r.nobs.index_select(0, idx);
  auto a = r.actions.index_select(0, idx);
  torch::Tensor mu, v;
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
  launch(r, last_value);
  return read_stats();
}

void Ppo::launch(const Rollout& r, const torch::Tensor& last_value) {
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
}

UpdateStats Ppo::read_stats() {
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

// Which of an actor-critic's parameters and buffers copy_state copies.
enum class Parts { all, but_obs_norm, obs_norm };

// Copies `parts` of `from` into `to` (the same networks).
void copy_state(ActorCriticImpl& from, ActorCriticImpl& to, Parts parts) {
  torch::NoGradGuard ng;
  auto wanted = [&](const std::string& key) {
    const bool norm = key.rfind("obs_norm.", 0) == 0;
    return parts == Parts::all || (parts == Parts::obs_norm) == norm;
  };
  auto dst = to.named_parameters();
  for (const auto& p : from.named_parameters())
    if (wanted(p.key())) dst[p.key()].copy_(p.value());
  auto dbuf = to.named_buffers();
  for (const auto& b : from.named_buffers())
    if (wanted(b.key())) dbuf[b.key()].copy_(b.value());
}

// A copy of `model` made without drawing from the global generator (a new ActorCritic draws its
// initial weights from it), so that a run draws the same numbers with ppo.overlap as without.
ActorCritic twin_of(ActorCritic& model, const PpoConfig& c, int64_t value_tasks) {
  auto gen = at::detail::getDefaultCPUGenerator();
  const auto state = gen.get_state();
  ActorCritic twin(model->obs_dim(), model->act_dim(), c, value_tasks);
  gen.set_state(state);
  twin->to(model->log_std().device());
  copy_state(*model, *twin, Parts::all);
  return twin;
}

class PpoAlgorithm final : public GaussianOnPolicy {
 public:
  PpoAlgorithm(const TrainConfig& config, int64_t D, int64_t A, int64_t N,
               const torch::Device& device, int64_t ntasks)
      : GaussianOnPolicy(config.ppo, D, A, N, device, config.ppo.value_norm_task ? ntasks : 0) {
    if (c_.overlap) {
      // the learner's own networks and rollout: model_ acts, one update behind
      learner_ = twin_of(model_, c_, config.ppo.value_norm_task ? ntasks : 0);
      lro_ = std::make_unique<Rollout>(c_.horizon, N, D, A, device);
#ifdef BIDEX_TORCH_CUDA
      if (device.is_cuda()) side_.emplace(c10::cuda::getStreamFromPool(false, device.index()));
#endif
    }
    ppo_ = std::make_unique<Ppo>(c_.overlap ? learner_ : model_, c_, ntasks);
  }

  ~PpoAlgorithm() override {
#ifdef BIDEX_TORCH_CUDA
    if (side_ && pending_) side_->synchronize();  // the update in flight reads our tensors
#endif
  }

  std::vector<double> update(const torch::Tensor& obs) override {
    const torch::Tensor last_value = finish_rollout(obs);
    if (!c_.overlap) {
      const UpdateStats us = ppo_->update(*ro_, last_value);
      return metrics(us, action_std());  // the std after the update
    }
    // the update in flight, if any, is done: the next rollout acts with its result, while the
    // update of the rollout just collected runs beside it
    std::vector<double> done = finish();
    {
      torch::NoGradGuard ng;
      // the acting networks take the learner's, the learner the acting observation normaliser
      copy_state(*learner_, *model_, Parts::but_obs_norm);
      copy_state(*model_, *learner_, Parts::obs_norm);
      lro_->copy_from(*ro_);
      if (!last_value_.defined()) last_value_ = torch::empty_like(last_value);
      last_value_.copy_(last_value);  // kept where it is: the update in flight reads it
    }
    {
#ifdef BIDEX_TORCH_CUDA
      std::optional<c10::cuda::CUDAStreamGuard> on_side;
      if (side_) {  // on the update's stream, after the copies above
        at::cuda::CUDAEvent copied;
        copied.record(c10::cuda::getCurrentCUDAStream(side_->device_index()));
        copied.block(*side_);
        on_side.emplace(*side_);
      }
#endif
      ppo_->launch(*lro_, last_value_);
    }
    pending_ = true;
    return done;
  }

  bool overlaps_update() const override { return c_.overlap; }

  std::vector<double> finish() override {
    if (!pending_) return {};
    pending_ = false;
    const UpdateStats us = [&] {
#ifdef BIDEX_TORCH_CUDA
      std::optional<c10::cuda::CUDAStreamGuard> on_side;  // read after the update, on its stream
      if (side_) on_side.emplace(*side_);
#endif
      return ppo_->read_stats();  // waits for the update: its parameters are final here
    }();
    return metrics(us, learner_std());
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

  // With ppo.overlap: "model" is the learner's networks (what evaluation and a resumed run's
  // learner load) and "acting" the acting copy, one update behind.
  void save(torch::serialize::OutputArchive& root) override {
    if (pending_)
      throw std::logic_error("PPO with ppo.overlap: save() with an update in flight (finish() first)");
    write_part(root, "model", c_.overlap ? *learner_ : *model_);
    write_part(root, "optimizer", ppo_->optimizer());  // its learning rate included
    if (c_.overlap) write_part(root, "acting", *model_);
  }

  void load(torch::serialize::InputArchive& root, const std::string& path) override {
    read_checked(path, "does not fit this run's networks", [&] {
      read_module(root, "model", c_.overlap ? *learner_ : *model_, path, "this run's networks");
      read_optimizer(root, "optimizer", ppo_->optimizer());
      if (!c_.overlap) return;
      torch::serialize::InputArchive acting;
      if (root.try_read("acting", acting))
        load_module_checked(*model_, acting, path, "this run's acting networks");
      else  // saved without ppo.overlap: the acting networks start as the learner's
        copy_state(*learner_, *model_, Parts::all);
    });
  }

  // Evaluation: the checkpoint's "model" into both networks (actor() acts with the learner's).
  void load_actor(torch::serialize::InputArchive& root, const std::string& path) override {
    GaussianOnPolicy::load_actor(root, path);
    if (c_.overlap) copy_state(*model_, *learner_, Parts::all);
  }

  torch::Tensor actor(const torch::Tensor& obs) override {
    if (!c_.overlap) return GaussianOnPolicy::actor(obs);
    torch::NoGradGuard ng;  // the newest policy, the learner's
    return learner_->mean(learner_->normalize_obs(obs)).clamp(-1.0, 1.0);
  }

 private:
  static std::vector<double> metrics(const UpdateStats& us, double action_std) {
    return {us.policy_loss, us.value_loss, us.entropy, us.kl, us.lr, us.clip_fraction,
            action_std};
  }
  double learner_std() const {
    torch::NoGradGuard ng;
    return torch::exp(learner_->log_std()).mean().item<double>();
  }

  std::unique_ptr<Ppo> ppo_;
  ActorCritic learner_{nullptr};   // ppo.overlap: the networks the updates step
  std::unique_ptr<Rollout> lro_;   // ppo.overlap: the rollout the update in flight reads
  torch::Tensor last_value_;
  bool pending_ = false;           // an update started whose metrics finish() has not taken
#ifdef BIDEX_TORCH_CUDA
  std::optional<c10::cuda::CUDAStream> side_;  // ppo.overlap on a CUDA device: the update's stream
#endif
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
