// The YAML sections of the offline algorithms (configs/train/bc.yaml, bcq.yaml, td3bc.yaml,
// iql.yaml), read strictly: unknown keys and bad values are ConfigErrors naming the key.
// Defaults (the section's files and these structs agree) are the original Bi-DexHands code's
// (bidexhands/algorithms/offrl and cfg/{td3_bc,bcq,iql}/config.yaml); BC, which it lacks, uses
// TD3+BC's actor and learning rate.
#pragma once

#include <string>
#include <vector>

#include "core/yaml.h"

namespace bidex::offline {

// The keys every offline section has.
struct OfflineConfig {
  bool obs_norm = true;       // observations normalised by the dataset's mean and std
  int batch_size = 256;       // transitions per gradient step
  int gradient_steps = 10000; // per update (the original trains 10000 between evaluations)
};

struct BcConfig : OfflineConfig {
  std::vector<int> hidden{256, 256};
  double lr = 3e-4;
};

struct Td3bcConfig : OfflineConfig {
  std::vector<int> hidden{256, 256};  // actor and each critic
  double actor_lr = 3e-4, critic_lr = 3e-4;
  double gamma = 0.99;
  double tau = 0.005;         // targets: tau x learned + (1 - tau) x target
  double policy_noise = 0.2;  // target policy smoothing: noise std ...
  double noise_clip = 0.5;    // ... clipped to +- this
  int policy_freq = 2;        // actor and target steps every this many critic steps
  double alpha = 0.2;         // the Q term's weight: lambda = alpha / mean |Q|
};

struct BcqConfig : OfflineConfig {
  BcqConfig() { batch_size = 100; }
  std::vector<int> actor_hidden{400, 300};  // the perturbation network
  std::vector<int> critic_hidden{400, 300};
  std::vector<int> vae_hidden{750, 750};    // encoder and decoder; latent 2 x act_dim
  double actor_lr = 1e-3, critic_lr = 1e-3, vae_lr = 1e-3;
  double gamma = 0.99;
  double tau = 0.005;
  double lmbda = 0.75;        // the target's weight of the smaller of the two critics
  double phi = 0.05;          // the largest perturbation of a decoded action
  int target_samples = 10;    // decoded actions per next state in the critics' target
  int eval_candidates = 100;  // decoded actions per state when acting
};

struct IqlConfig : OfflineConfig {
  std::vector<int> hidden{256, 256};  // Q1, Q2, V and the policy
  double q_lr = 3e-4, v_lr = 3e-4, policy_lr = 3e-4;
  double gamma = 0.99;
  double tau = 0.005;
  double expectile = 0.7;
  double beta = 3.0;          // advantage weights exp(beta x (Q - V)) ...
  double max_weight = 100.0;  // ... at most this
  bool double_tanh = true;    // the original's policy density (iql.cc)
};

BcConfig read_bc(const YamlView& section);
Td3bcConfig read_td3bc(const YamlView& section);
BcqConfig read_bcq(const YamlView& section);
IqlConfig read_iql(const YamlView& section);

}  // namespace bidex::offline
