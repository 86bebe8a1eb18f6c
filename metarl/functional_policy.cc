#include "metarl/functional_policy.h"

#include <cmath>
#include <stdexcept>

#include "rl/policy.h"

namespace bidex::metarl {

namespace {

torch::Tensor activate(const std::string& activation, const torch::Tensor& x) {
  // the same choice as rl::mlp (init() has refused any other name)
  if (activation == "elu") return torch::elu(x);
  if (activation == "relu") return torch::relu(x);
  return torch::tanh(x);
}

std::string shape_of(const torch::Tensor& t) {
  std::string s = "[";
  for (int64_t i = 0; i < t.dim(); ++i) s += (i ? ", " : "") + std::to_string(t.size(i));
  return s + "]";
}

}  // namespace

FunctionalGaussian FunctionalGaussian::init(int64_t obs_dim, const std::vector<int>& hidden,
                                            int64_t act_dim, const std::string& activation,
                                            double init_std, uint64_t seed) {
  if (obs_dim <= 0 || act_dim <= 0)
    throw std::invalid_argument("FunctionalGaussian: obs_dim and act_dim must be positive, got " +
                                std::to_string(obs_dim) + " and " + std::to_string(act_dim));
  for (int h : hidden)
    if (h <= 0)
      throw std::invalid_argument("FunctionalGaussian: hidden widths must be positive, got " +
                                  std::to_string(h));
  if (activation != "elu" && activation != "relu" && activation != "tanh")
    throw std::invalid_argument("FunctionalGaussian: activation must be elu, relu or tanh, got '" +
                                activation + "'");
  if (!(init_std > 0))
    throw std::invalid_argument("FunctionalGaussian: init_std must be positive, got " +
                                std::to_string(init_std));

  FunctionalGaussian pi;
  pi.obs_dim = obs_dim;
  pi.act_dim = act_dim;
  pi.hidden = hidden;
  pi.activation = activation;

  // draw rl::mlp's initialisation (so the two policies start alike) from the seeded global
  // generator, and put the generator back so the caller's random stream does not move
  auto gen = at::detail::getDefaultCPUGenerator();
  const auto saved = gen.get_state();
  gen.set_current_seed(seed);
  auto net = rl::mlp(obs_dim, hidden, act_dim, activation, /*out_gain=*/0.01);
  gen.set_state(saved);

  // Sequential::parameters() lists each Linear's weight then bias, layer by layer
  for (const auto& p : net->parameters()) pi.params.push_back(p.detach().clone());
  pi.params.push_back(torch::full({act_dim}, std::log(init_std)));
  for (auto& p : pi.params) p.set_requires_grad(true);
  pi.check(pi.params);
  return pi;
}

void FunctionalGaussian::check(const std::vector<torch::Tensor>& p) const {
  const size_t layers = hidden.size() + 1;
  if (p.size() != 2 * layers + 1)
    throw std::invalid_argument("FunctionalGaussian: expected " + std::to_string(2 * layers + 1) +
                                " parameter tensors, got " + std::to_string(p.size()));
  int64_t width = obs_dim;
  for (size_t l = 0; l < layers; ++l) {
    const int64_t out = l < hidden.size() ? hidden[l] : act_dim;
    const auto& w = p[2 * l];
    const auto& b = p[2 * l + 1];
    if (w.dim() != 2 || w.size(0) != out || w.size(1) != width || b.dim() != 1 ||
        b.size(0) != out)
      throw std::invalid_argument("FunctionalGaussian: layer " + std::to_string(l) +
                                  " expected weight [" + std::to_string(out) + ", " +
                                  std::to_string(width) + "] and bias [" + std::to_string(out) +
                                  "], got " + shape_of(w) + " and " + shape_of(b));
    width = out;
  }
  if (p.back().dim() != 1 || p.back().size(0) != act_dim)
    throw std::invalid_argument("FunctionalGaussian: expected log_std [" +
                                std::to_string(act_dim) + "], got " + shape_of(p.back()));
}

void FunctionalGaussian::to(const torch::TensorOptions& options) {
  for (auto& p : params) p = p.detach().to(options).set_requires_grad(true);
}

torch::Tensor FunctionalGaussian::mean(const std::vector<torch::Tensor>& p,
                                       const torch::Tensor& obs) const {
  torch::Tensor x = obs;
  for (size_t l = 0; l < hidden.size(); ++l)
    x = activate(activation, torch::linear(x, p[2 * l], p[2 * l + 1]));
  const size_t out = 2 * hidden.size();
  return torch::linear(x, p[out], p[out + 1]);
}

torch::Tensor FunctionalGaussian::log_prob(const std::vector<torch::Tensor>& p,
                                           const torch::Tensor& obs,
                                           const torch::Tensor& actions) const {
  return rl::gaussian_log_prob(actions, mean(p, obs), log_std(p));
}

torch::Tensor FunctionalGaussian::kl(const std::vector<torch::Tensor>& p_old,
                                     const std::vector<torch::Tensor>& p_new,
                                     const torch::Tensor& obs) const {
  return rl::gaussian_kl(mean(p_old, obs), log_std(p_old), mean(p_new, obs), log_std(p_new))
      .mean();
}

torch::Tensor FunctionalGaussian::entropy(const std::vector<torch::Tensor>& p) const {
  return rl::gaussian_entropy(log_std(p));
}

std::vector<torch::Tensor> detached(const std::vector<torch::Tensor>& p) {
  std::vector<torch::Tensor> out;
  out.reserve(p.size());
  for (const auto& t : p) out.push_back(t.detach().clone().set_requires_grad(true));
  return out;
}

}  // namespace bidex::metarl
