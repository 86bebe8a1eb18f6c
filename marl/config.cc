#include "marl/config.h"

#include "marl/agents.h"
#include "rl/config_fields.h"
#include "tasks/registry.h"

namespace bidex::marl {

namespace {

NetConfig read_net(const YamlView& p) {
  NetConfig n;
  n.hidden = rl::read_widths(p.child("hidden"));
  n.activation = rl::read_choice(p, "activation", {"elu", "relu", "tanh"});
  n.feature_norm = p.req<bool>("feature_norm");
  n.layer_norm = p.req<bool>("layer_norm");
  return n;
}

// `agents`: hand, finger, or a list (its entries are checked against the task's layout when
// the run starts: marl/agents.h)
void check_agents_form(const YamlView& p) {
  const YamlView a = p.child("agents");
  if (a.node().IsSequence() && a.node().size() > 0) return;
  if (a.node().IsScalar()) {
    const std::string s = a.node().as<std::string>();
    if (s == "hand" || s == "finger") return;
  }
  a.fail("hand, finger, or a list of agents (marl/agents.h)", a.repr());
}

double lr(const YamlView& p, const char* key) { return rl::read_real(p, key, 0, 1, true); }
double unit(const YamlView& p, const char* key) { return rl::read_real(p, key, 0, 1, false); }
double nonneg(const YamlView& p, const char* key) { return rl::read_real(p, key, 0, 1e9, false); }

}  // namespace

OnPolicyConfig read_onpolicy(const YamlView& p, const std::string& algo) {
  std::vector<std::string> keys = {
      "agents",      "hidden",     "activation",      "feature_norm", "layer_norm",
      "horizon",     "epochs",     "minibatches",     "clip",         "critic_lr",
      "adam_eps",    "gamma",      "lambda",          "max_grad_norm", "entropy_coef",
      "value_coef",  "clip_value_loss", "huber_delta", "value_norm",  "obs_norm",
      "std_x_coef",  "std_y_coef", "log_std_init"};
  const bool trpo = algo == "hatrpo";
  if (trpo)
    keys.insert(keys.end(), {"kl_threshold", "cg_iters", "damping", "backtracks", "accept_ratio"});
  else
    keys.push_back("lr");
  if (algo == "mappo") keys.push_back("share_actor");
  if (algo == "happo" || trpo) keys.push_back("fixed_order");
  p.allow_keys(keys);
  check_agents_form(p);
  OnPolicyConfig c;
  c.net = read_net(p);
  c.horizon = rl::read_int(p, "horizon", 1);
  c.epochs = rl::read_int(p, "epochs", 1);
  c.minibatches = rl::read_int(p, "minibatches", 1);
  c.clip = rl::read_real(p, "clip", 0, 1, true);
  if (!trpo) c.lr = lr(p, "lr");
  c.critic_lr = lr(p, "critic_lr");
  c.adam_eps = rl::read_real(p, "adam_eps", 0, 1, true);
  c.gamma = unit(p, "gamma");
  c.lambda = unit(p, "lambda");
  c.max_grad_norm = rl::read_real(p, "max_grad_norm", 0, 1e9, true);
  c.entropy_coef = nonneg(p, "entropy_coef");
  c.value_coef = nonneg(p, "value_coef");
  c.clip_value_loss = p.req<bool>("clip_value_loss");
  c.huber_delta = nonneg(p, "huber_delta");
  c.value_norm = p.req<bool>("value_norm");
  c.obs_norm = p.req<bool>("obs_norm");
  c.std_x_coef = rl::read_real(p, "std_x_coef", 0, 1e6, true);
  c.std_y_coef = rl::read_real(p, "std_y_coef", 0, 1e6, true);
  c.log_std_init = rl::read_real(p, "log_std_init", -1e3, 1e3, false);
  if (algo == "mappo") c.share_actor = p.req<bool>("share_actor");
  if (algo == "happo" || trpo) c.fixed_order = p.req<bool>("fixed_order");
  if (trpo) {
    c.kl_threshold = rl::read_real(p, "kl_threshold", 0, 10, true);
    c.cg_iters = rl::read_int(p, "cg_iters", 1);
    c.damping = nonneg(p, "damping");
    c.backtracks = rl::read_int(p, "backtracks", 1);
    c.accept_ratio = unit(p, "accept_ratio");
  }
  return c;
}

MaddpgConfig read_maddpg(const YamlView& p) {
  p.allow_keys({"agents", "hidden", "activation", "feature_norm", "layer_norm", "horizon",
                "gradient_steps", "policy_freq", "batch_size", "replay_size", "warmup_steps",
                "lr", "critic_lr", "gamma", "polyak", "expl_noise", "huber_delta",
                "max_grad_norm", "reward_scale", "preact_l2"});
  check_agents_form(p);
  MaddpgConfig c;
  c.net = read_net(p);
  c.horizon = rl::read_int(p, "horizon", 1);
  c.gradient_steps = rl::read_int(p, "gradient_steps", 1);
  c.policy_freq = rl::read_int(p, "policy_freq", 1);
  c.batch_size = rl::read_int(p, "batch_size", 1);
  c.replay_size = rl::read_int(p, "replay_size", 1);
  c.warmup_steps = rl::read_int(p, "warmup_steps", 0);
  c.lr = lr(p, "lr");
  c.critic_lr = lr(p, "critic_lr");
  c.gamma = unit(p, "gamma");
  c.polyak = rl::read_real(p, "polyak", 0, 1, true);
  c.expl_noise = rl::read_real(p, "expl_noise", 0, 10, false);
  c.huber_delta = nonneg(p, "huber_delta");
  c.max_grad_norm = rl::read_real(p, "max_grad_norm", 0, 1e9, true);
  c.reward_scale = rl::read_real(p, "reward_scale", 0, 1e6, true);
  c.preact_l2 = nonneg(p, "preact_l2");
  return c;
}

YamlView section_of(const rl::TrainConfig& config) {
  return YamlView::load_string(config.section_yaml, config.algo + " section");
}

AgentSplit run_agents(const rl::TrainConfig& config, int64_t obs_dim, int64_t act_dim) {
  const tasks::TaskSpec& spec = tasks::find_task(config.task).spec();
  AgentSplit split = split_agents(spec, section_of(config).child("agents"));
  if (split.obs_dim != obs_dim || split.act_dim != act_dim)
    throw Error(config.algo + ": the agents' split of task " + config.task +
                " covers observations of width " + std::to_string(split.obs_dim) +
                " and actions of width " + std::to_string(split.act_dim) + ", but the run's are " +
                std::to_string(obs_dim) + " and " + std::to_string(act_dim));
  return split;
}

}  // namespace bidex::marl
