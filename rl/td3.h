// TD3 (Fujimoto et al. 2018) and DDPG (Lillicrap et al. 2015) on the learning core: a
// deterministic tanh actor explored with Gaussian action noise, critics with Polyak-averaged
// target networks, and the ReplayBuffer. Each update follows `horizon` steps of every slot with
// epochs x minibatches gradient steps on `batch_size` sampled transitions. TD3 adds a second
// critic (the minimum of the two in the target), target policy smoothing (clipped noise on the
// target action) and a delayed actor: the actor and the targets move every `policy_delay`
// critic steps. DDPG is the same class with one critic, no smoothing and no delay. The actor and
// the critics step with FlatAdam (rl/flat_adam.h; the checkpoint parts actor_optimizer and
// critic_optimizer, which load LibTorch Adam's state of older checkpoints too).
// Optionally (preact_l2 > 0) the actor's loss also penalises its squared pre-tanh output, as
// Andrychowicz et al. 2017 (hindsight experience replay) do against tanh saturation: without it,
// on catch_underarm_raise every action component sits at +-1 within a few updates, where tanh's
// gradient vanishes, and the policy stays there (the metric `saturated` shows it).
#pragma once

#include <memory>

#include <torch/torch.h>

#include "rl/algorithm.h"

namespace bidex::rl {

// The target action: clamp(mu' + clamp(noise x std, -clip, clip), -1, 1), where `noise` is a
// standard normal draw (std 0: mu' clamped).
torch::Tensor td3_target_action(const torch::Tensor& mu_next, const torch::Tensor& noise,
                                double std, double clip);
// The critics' target: r + gamma (1 - terminal) min(q1', q2') (DDPG: pass q1' twice).
torch::Tensor td3_q_target(const torch::Tensor& reward, const torch::Tensor& terminal,
                           const torch::Tensor& q1_next, const torch::Tensor& q2_next,
                           double gamma);
// The actor's loss: -mean(q) + preact_l2 x mean(preact^2), q [B] the first critic's value of
// the actor's action tanh(preact) [B, A].
torch::Tensor td3_actor_loss(const torch::Tensor& q, const torch::Tensor& preact,
                             double preact_l2);
// Whether gradient step `step` (counted from 0 over the run) moves the actor and the targets.
inline bool td3_actor_step(int64_t step, int policy_delay) {
  return (step + 1) % policy_delay == 0;
}

// td3 or ddpg, by the config's section (config.td3.twin).
std::unique_ptr<Algorithm> make_td3(const TrainConfig& config, int64_t obs_dim, int64_t act_dim,
                                    int64_t nslot, const torch::Device& device);

}  // namespace bidex::rl
