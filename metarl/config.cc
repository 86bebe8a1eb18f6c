#include "metarl/config.h"

#include "rl/config_fields.h"

namespace bidex::metarl {

namespace {
// input_norm and task_reward_norm (and MAML's and ProMP's learn_inner_lr), optional: runs made
// before they existed have none, and their checkpoints hold none
void read_scale_options(const YamlView& p, bool& input_norm, bool& task_reward_norm) {
  if (auto v = p.maybe("input_norm")) input_norm = v->as<bool>();
  if (auto v = p.maybe("task_reward_norm")) task_reward_norm = v->as<bool>();
}
}  // namespace

GradientMetaConfig read_gradient_meta(const YamlView& p, bool promp) {
  std::vector<std::string> keys = {"hidden", "activation", "init_std", "horizon", "inner_steps",
                                   "inner_lr", "first_order", "epochs", "lr", "clip", "gamma",
                                   "lambda", "max_grad_norm"};
  if (promp) keys.insert(keys.end(), {"init_kl_coef", "target_kl"});
  keys.insert(keys.end(), {"input_norm", "task_reward_norm", "learn_inner_lr"});
  p.allow_keys(keys);
  GradientMetaConfig c;
  c.hidden = rl::read_widths(p.child("hidden"));
  c.activation = rl::read_choice(p, "activation", {"elu", "relu", "tanh"});
  c.init_std = rl::read_real(p, "init_std", 0, 1e3, true);
  c.horizon = rl::read_int(p, "horizon", 1);
  c.inner_steps = rl::read_int(p, "inner_steps", 0);
  c.inner_lr = rl::read_real(p, "inner_lr", 0, 1e3, false);
  c.first_order = p.req<bool>("first_order");
  c.epochs = rl::read_int(p, "epochs", 1);
  c.lr = rl::read_real(p, "lr", 0, 1, true);
  c.clip = rl::read_real(p, "clip", 0, 1, true);
  c.gamma = rl::read_real(p, "gamma", 0, 1, false);
  c.lambda = rl::read_real(p, "lambda", 0, 1, false);
  c.max_grad_norm = rl::read_real(p, "max_grad_norm", 0, 1e9, true);
  if (promp) {
    c.init_kl_coef = rl::read_real(p, "init_kl_coef", 0, 1e6, false);
    c.target_kl = rl::read_real(p, "target_kl", 0, 10, true);
  } else {
    c.init_kl_coef = 0;
  }
  read_scale_options(p, c.input_norm, c.task_reward_norm);
  if (auto v = p.maybe("learn_inner_lr")) c.learn_inner_lr = v->as<bool>();
  return c;
}

Rl2Config read_rl2(const YamlView& p) {
  p.allow_keys({"hidden_size", "init_std", "horizon", "epochs", "minibatches", "clip", "lr",
                "gamma", "lambda", "max_grad_norm", "entropy_coef", "value_coef",
                "trial_episodes", "input_norm", "task_reward_norm"});
  Rl2Config c;
  c.hidden_size = rl::read_int(p, "hidden_size", 1);
  c.init_std = rl::read_real(p, "init_std", 0, 1e3, true);
  c.horizon = rl::read_int(p, "horizon", 1);
  c.epochs = rl::read_int(p, "epochs", 1);
  c.minibatches = rl::read_int(p, "minibatches", 1);
  c.clip = rl::read_real(p, "clip", 0, 1, true);
  c.lr = rl::read_real(p, "lr", 0, 1, true);
  c.gamma = rl::read_real(p, "gamma", 0, 1, false);
  c.lambda = rl::read_real(p, "lambda", 0, 1, false);
  c.max_grad_norm = rl::read_real(p, "max_grad_norm", 0, 1e9, true);
  c.entropy_coef = rl::read_real(p, "entropy_coef", 0, 1e3, false);
  c.value_coef = rl::read_real(p, "value_coef", 0, 1e3, false);
  c.trial_episodes = rl::read_int(p, "trial_episodes", 1);
  read_scale_options(p, c.input_norm, c.task_reward_norm);
  return c;
}

}  // namespace bidex::metarl
