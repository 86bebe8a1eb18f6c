#include "offline/config.h"

#include "rl/config_fields.h"

namespace bidex::offline {

namespace {

// allow_keys over the section's own keys and the shared ones, then the shared ones
void read_common(const YamlView& p, std::vector<std::string> keys, OfflineConfig& c) {
  keys.insert(keys.end(), {"obs_norm", "batch_size", "gradient_steps"});
  p.allow_keys(keys);
  c.obs_norm = p.req<bool>("obs_norm");
  c.batch_size = rl::read_int(p, "batch_size", 1);
  c.gradient_steps = rl::read_int(p, "gradient_steps", 1);
}

double lr(const YamlView& p, const char* key) { return rl::read_real(p, key, 0, 1, true); }
double unit(const YamlView& p, const char* key) { return rl::read_real(p, key, 0, 1, false); }

}  // namespace

BcConfig read_bc(const YamlView& p) {
  BcConfig c;
  read_common(p, {"hidden", "lr"}, c);
  c.hidden = rl::read_widths(p.child("hidden"));
  c.lr = lr(p, "lr");
  return c;
}

Td3bcConfig read_td3bc(const YamlView& p) {
  Td3bcConfig c;
  read_common(p,
              {"hidden", "actor_lr", "critic_lr", "gamma", "tau", "policy_noise", "noise_clip",
               "policy_freq", "alpha"},
              c);
  c.hidden = rl::read_widths(p.child("hidden"));
  c.actor_lr = lr(p, "actor_lr");
  c.critic_lr = lr(p, "critic_lr");
  c.gamma = unit(p, "gamma");
  c.tau = unit(p, "tau");
  c.policy_noise = rl::read_real(p, "policy_noise", 0, 10, false);
  c.noise_clip = rl::read_real(p, "noise_clip", 0, 10, false);
  c.policy_freq = rl::read_int(p, "policy_freq", 1);
  c.alpha = rl::read_real(p, "alpha", 0, 1e6, false);
  return c;
}

BcqConfig read_bcq(const YamlView& p) {
  BcqConfig c;
  read_common(p,
              {"actor_hidden", "critic_hidden", "vae_hidden", "actor_lr", "critic_lr", "vae_lr",
               "gamma", "tau", "lmbda", "phi", "target_samples", "eval_candidates"},
              c);
  c.actor_hidden = rl::read_widths(p.child("actor_hidden"));
  c.critic_hidden = rl::read_widths(p.child("critic_hidden"));
  c.vae_hidden = rl::read_widths(p.child("vae_hidden"));
  c.actor_lr = lr(p, "actor_lr");
  c.critic_lr = lr(p, "critic_lr");
  c.vae_lr = lr(p, "vae_lr");
  c.gamma = unit(p, "gamma");
  c.tau = unit(p, "tau");
  c.lmbda = unit(p, "lmbda");
  c.phi = rl::read_real(p, "phi", 0, 2, false);
  c.target_samples = rl::read_int(p, "target_samples", 1);
  c.eval_candidates = rl::read_int(p, "eval_candidates", 1);
  return c;
}

IqlConfig read_iql(const YamlView& p) {
  IqlConfig c;
  read_common(p,
              {"hidden", "q_lr", "v_lr", "policy_lr", "gamma", "tau", "expectile", "beta",
               "max_weight", "double_tanh"},
              c);
  c.hidden = rl::read_widths(p.child("hidden"));
  c.q_lr = lr(p, "q_lr");
  c.v_lr = lr(p, "v_lr");
  c.policy_lr = lr(p, "policy_lr");
  c.gamma = unit(p, "gamma");
  c.tau = unit(p, "tau");
  c.expectile = rl::read_real(p, "expectile", 0, 1, true);
  c.beta = rl::read_real(p, "beta", 0, 1e3, false);
  c.max_weight = rl::read_real(p, "max_weight", 0, 1e9, true);
  c.double_tanh = p.req<bool>("double_tanh");
  return c;
}

}  // namespace bidex::offline
