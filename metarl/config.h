// The YAML sections of the meta-RL algorithms (configs/train/maml.yaml, promp.yaml, rl2.yaml),
// read strictly: unknown keys and bad values are ConfigErrors naming the key.
#pragma once

#include <string>
#include <vector>

#include "core/yaml.h"
#include "metarl/rl2.h"

namespace bidex::metarl {

// MAML and ProMP: a meta-update follows `horizon` steps of every slot with the meta-policy, one
// adaptation per task from them, and `horizon` steps with each task's adapted policy.
struct GradientMetaConfig {
  std::vector<int> hidden{2048, 1024, 512};
  std::string activation = "elu";
  double init_std = 1.0;
  int horizon = 8;           // steps of every slot before adaptation, and as many after it
  int inner_steps = 1;       // gradient steps of the adaptation
  double inner_lr = 3e-4;
  bool first_order = false;  // drop the adaptation's second-order term from the outer gradient
  int epochs = 3;            // outer steps per meta-update (each re-adapts differentiably)
  double lr = 3e-4;          // outer Adam: meta-policy and critic
  double clip = 0.2;         // the outer clipped surrogate
  double gamma = 0.9;
  double lambda = 0.95;
  double max_grad_norm = 1.0;
  // ProMP only: the KL penalty keeping the meta-policy near the one that sampled
  double init_kl_coef = 5e-4;
  double target_kl = 0.016;
  // The policy and the critic read observations normalised by a running mean and std (kept in
  // checkpoints), updated from the training rollouts only.
  bool input_norm = false;
  // Each task's rewards are divided by the running std of its discounted returns before the
  // advantages and the critic's targets (task_scale.h); at evaluation, by the std of the
  // adaptation rows' own returns.
  bool task_reward_norm = false;
  // Meta-SGD (maml.h, StepSize): the inner step size is one tensor per parameter, each element
  // starting at inner_lr, learned by the outer loss with the meta-policy (kept in checkpoints).
  // Learned as alpha = inner_lr exp(rho): positive, and the outer Adam's steps (lr) change it by
  // a fraction of itself (Meta-SGD learned alpha itself, whose steps of lr = 3e-4 would be as
  // large as ProMP's inner_lr of 3e-4).
  bool learn_inner_lr = false;
};

GradientMetaConfig read_gradient_meta(const YamlView& section, bool promp);
Rl2Config read_rl2(const YamlView& section);

}  // namespace bidex::metarl
