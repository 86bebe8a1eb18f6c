// The learning side's networks: a running normaliser, and the actor-critic of PPO (an MLP actor
// giving the mean of a Gaussian with a learned state-independent log-std, and a separate MLP
// critic). Pulls in LibTorch: include it only in rl/ sources and the commands that train.
#pragma once

#include <torch/torch.h>

#include "rl/config.h"

namespace bidex::rl {

// Chan et al.'s parallel update of running moments, element-wise: the running count, mean and
// population variance (updated in place) merged with a batch's n rows, their mean and variance.
// Where the merged count is 0 the moments stay as they are.
void merge_moments(torch::Tensor& count, torch::Tensor& mean, torch::Tensor& var,
                   const torch::Tensor& n, const torch::Tensor& bmean, const torch::Tensor& bvar);

// Running mean and variance of vectors (Chan's parallel update, in float64), and the
// normalisation clamp((x - mean) / sqrt(var + eps), -clip, clip). Its state is buffers, so it is
// saved and loaded with the module that owns it. Grouped (`groups` true): `dim` scalar series
// kept apart, each with its own count, and a row's series named by its group.
class RunningNormImpl : public torch::nn::Module {
 public:
  explicit RunningNormImpl(int64_t dim, double clip = 5.0, bool groups = false);
  // x: [batch, dim] (any floating type, any device the module is on)
  void update(const torch::Tensor& x);
  torch::Tensor normalize(const torch::Tensor& x) const;
  // Scale back (value normalisation): x * std + mean, no clamp.
  torch::Tensor denormalize(const torch::Tensor& x) const;
  // Scalars x with their groups (long, < dim; the same shape) on a grouped normaliser; with
  // `groups` undefined, on a one-dimensional one as [batch, 1]. Nothing is read back.
  void update(const torch::Tensor& x, const torch::Tensor& groups);
  torch::Tensor normalize(const torch::Tensor& x, const torch::Tensor& groups) const;
  torch::Tensor denormalize(const torch::Tensor& x, const torch::Tensor& groups) const;
  // rows seen (over every group)
  double count() const { return count_.sum().item<double>(); }

 private:
  double clip_;
  torch::Tensor mean_, var_, count_;
};
TORCH_MODULE(RunningNorm);

// Moments of scalars `x` per group (`groups`: long, < ngroups, x's shape), by index_add with
// no host read: the count, the mean, each value's deviation from its group's mean (x's shape)
// and the sum of squared deviations. Per-task advantages (rl/ppo.cc) and a grouped RunningNorm
// take their variances from it.
struct GroupMoments {
  torch::Tensor count, mean, dev, sq_dev;
};
GroupMoments group_moments(const torch::Tensor& x, const torch::Tensor& groups, int64_t ngroups);

// A diagonal Gaussian's log-density of `a` (summed over the last axis) and its entropy.
torch::Tensor gaussian_log_prob(const torch::Tensor& a, const torch::Tensor& mean,
                                const torch::Tensor& log_std);
torch::Tensor gaussian_entropy(const torch::Tensor& log_std);
// KL(old || new) of two diagonal Gaussians, summed over the last axis.
torch::Tensor gaussian_kl(const torch::Tensor& mu_old, const torch::Tensor& log_std_old,
                          const torch::Tensor& mu_new, const torch::Tensor& log_std_new);

// The task of each row of a multi-task pack's observations (the last axis: any leading shape):
// the column of the one-hot id, the last `ntasks` columns (raw or normalised by the running mean and std: a task's own column is
// the only one above its mean).
torch::Tensor task_ids(const torch::Tensor& obs, int64_t ntasks);

// A multilayer perceptron: `hidden` layers of `activation` (elu, relu or tanh), orthogonal
// weights with gain sqrt 2 and `out_gain` for the output layer, zero biases. With `align` > 1
// a layer whose input or output width is not a multiple of `align` is a PaddedLinear of the same
// initial weights (the network's outputs are the same up to the order of summation). With
// `bias_grad_gemm` every layer is a PaddedLinear whose bias gradient is a matrix product
// (linear_gemm_bias_grad).
torch::nn::Sequential mlp(int64_t in, const std::vector<int>& hidden, int64_t out,
                          const std::string& activation, double out_gain, int64_t align = 1,
                          bool bias_grad_gemm = false);

// x W^T + b as torch::nn::functional::linear, with the bias gradient taken as a matrix product
// (a row of ones times the output's gradient) instead of a sum over the rows: on a GPU a
// bfloat16 column sum of 8,192 rows is a slow reduction kernel, the product a fast one. Under
// autocast the product and the saved inputs are in the autocast type, as linear's; the
// gradients come back in the parameters' types. Any leading shape of x.
torch::Tensor linear_gemm_bias_grad(const torch::Tensor& x, const torch::Tensor& weight,
                                    const torch::Tensor& bias);

// A linear layer whose weight and bias carry zero rows and columns up to widths that are
// multiples of `align`: forward() pads its input with zero columns (unless it comes padded) and
// returns the first `out` columns, so that the matrix products see rows of aligned length (a
// GPU's tensor-core kernels want 16-byte rows, 8 bfloat16 or 4 float32 values; an observation of
// 422 is neither). The padded entries multiply zeros and are sliced away, so they get zero
// gradients and stay zero under Adam and gradient clipping. Its parameters are named `weight` and
// `bias`, as torch::nn::Linear's.
class PaddedLinearImpl : public torch::nn::Module {
 public:
  // from a [out, in] layer's weight and bias; `bias_grad_gemm`: forward() is
  // linear_gemm_bias_grad (align 1 then pads nothing)
  PaddedLinearImpl(const torch::Tensor& weight, const torch::Tensor& bias, int64_t align,
                   bool bias_grad_gemm = false);
  torch::Tensor forward(const torch::Tensor& x);
  torch::Tensor weight, bias;  // [out padded, in padded], [out padded]

 private:
  int64_t in_, out_;
  bool bias_grad_gemm_;
};
TORCH_MODULE(PaddedLinear);

// Target networks: dst = keep x dst + (1 - keep) x src, parameter by parameter (keep = 0 copies).
void polyak_update(torch::nn::Module& src, torch::nn::Module& dst, double keep);
// A target network's start: a copy of `src` that never takes gradients.
void make_target(torch::nn::Module& src, torch::nn::Module& target);

// Q(s, a) on the observation and action side by side: two critics (`q1`, `q2`) for SAC's and
// TD3's clipped double Q, or one (`twin` false, DDPG), whose value forward() then gives twice.
struct QCriticImpl : torch::nn::Module {
  QCriticImpl(int64_t obs_dim, int64_t act_dim, const std::vector<int>& hidden,
              const std::string& activation, bool twin);
  // From given networks of input obs_dim + act_dim and output 1 (q2 null: one critic); the
  // offline family's keep their original's initialisation.
  QCriticImpl(torch::nn::Sequential q1_net, torch::nn::Sequential q2_net);
  // (q1, q2), each [n]
  std::pair<torch::Tensor, torch::Tensor> forward(const torch::Tensor& obs,
                                                  const torch::Tensor& actions);
  // q1 alone, [n] (actor losses)
  torch::Tensor first(const torch::Tensor& obs, const torch::Tensor& actions);
  torch::nn::Sequential q1{nullptr}, q2{nullptr};
};
TORCH_MODULE(QCritic);

class ActorCriticImpl : public torch::nn::Module {
 public:
  // value_tasks > 0 (value_norm per task): the returns are normalised within each of that many
  // tasks, each row's task read from the one-hot id that ends its observation
  ActorCriticImpl(int64_t obs_dim, int64_t act_dim, const PpoConfig& config,
                  int64_t value_tasks = 0);

  // Observations as the environment gives them (normalised inside when obs_norm is on).
  torch::Tensor normalize_obs(const torch::Tensor& obs) const;
  // On normalised observations: the action mean, and the value in return units (in the
  // observations' type, also where autocast runs the critic's products in another).
  torch::Tensor mean(const torch::Tensor& nobs);
  torch::Tensor value(const torch::Tensor& nobs);
  // The critic's raw output (normalised units when value_norm is on).
  torch::Tensor raw_value(const torch::Tensor& nobs);
  // The value normaliser's group of each row: its task (value_tasks > 0), else undefined.
  torch::Tensor value_groups(const torch::Tensor& nobs) const;
  torch::Tensor log_std() const { return log_std_; }
  // The policy's parameters (the mean network and the log-std) and the critic's, apart.
  std::vector<torch::Tensor> actor_parameters() const;
  std::vector<torch::Tensor> critic_parameters() const { return critic_->parameters(); }

  RunningNorm& obs_norm() { return obs_norm_; }
  RunningNorm& value_norm() { return value_norm_; }
  bool uses_obs_norm() const { return use_obs_norm_; }
  bool uses_value_norm() const { return use_value_norm_; }
  int64_t obs_dim() const { return obs_dim_; }
  int64_t act_dim() const { return act_dim_; }
  // The width of the networks' first products: obs_dim with the zero columns that align_widths
  // pads it with. mean() and raw_value() also take observations already padded so.
  int64_t input_width() const { return actor_->parameters()[0].size(1); }

 private:
  int64_t obs_dim_, act_dim_, value_tasks_;
  bool use_obs_norm_, use_value_norm_;
  torch::nn::Sequential actor_{nullptr}, critic_{nullptr};
  torch::Tensor log_std_;
  RunningNorm obs_norm_{nullptr}, value_norm_{nullptr};
};
TORCH_MODULE(ActorCritic);

}  // namespace bidex::rl
