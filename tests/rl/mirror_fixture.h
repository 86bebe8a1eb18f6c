// Helpers of the optimiser equivalence tests (sac_test, td3_test, trpo_test): a learner's state
// read back from its checkpoint archive into copies of its networks (a "mirror" that repeats the
// learner's update with LibTorch's Adam and clip_grad_norm_, the optimisers it had before
// FlatAdam), and the comparison of the two afterwards.
#pragma once

#include "tests/rl/rl_fixture.h"

#include <algorithm>
#include <sstream>
#include <string>

#include "rl/algorithm.h"

namespace bidex::test {

// What `saver` saves (an Algorithm's checkpoint state, a FlatAdam's) as an archive to read.
template <class Saver>
torch::serialize::InputArchive saved_state(Saver& saver) {
  torch::serialize::OutputArchive out;
  saver.save(out);
  std::ostringstream bytes;
  out.save_to(bytes);
  torch::serialize::InputArchive in;
  std::istringstream is(bytes.str());
  in.load_from(is);
  return in;
}

// Loads the module part `name` of a checkpoint archive into `m`.
inline void load_part(torch::serialize::InputArchive& root, const std::string& name,
                      torch::nn::Module& m) {
  torch::serialize::InputArchive a;
  root.read(name, a);
  m.load(a);
}

// Largest |a - b| over two lists of tensors, in order.
inline double max_diff(const std::vector<torch::Tensor>& a, const std::vector<torch::Tensor>& b) {
  REQUIRE(a.size() == b.size());
  double worst = 0;
  for (size_t k = 0; k < a.size(); ++k) {
    REQUIRE(a[k].sizes() == b[k].sizes());
    worst = std::max(worst, (a[k] - b[k]).abs().max().item<double>());
  }
  return worst;
}

// Deep copies of a module's parameters (to measure how far an update moved them).
inline std::vector<torch::Tensor> param_copies(torch::nn::Module& m) {
  std::vector<torch::Tensor> out;
  for (auto& p : m.parameters()) out.push_back(p.detach().clone());
  return out;
}

// The mirror's gradient norms before its clips (clip_grad_norm_'s): each clip (the critic's, and
// the actor's unless `actor` is empty) bound on some step, and some clip did not bind on some
// step, so that the equivalence covers both of the clip's regimes.
inline void check_clips(const std::vector<double>& critic, const std::vector<double>& actor,
                        double max_norm) {
  REQUIRE_FALSE(critic.empty());
  std::vector<double> all = critic;
  all.insert(all.end(), actor.begin(), actor.end());
  CHECK(*std::max_element(critic.begin(), critic.end()) > max_norm);
  if (!actor.empty()) CHECK(*std::max_element(actor.begin(), actor.end()) > max_norm);
  CHECK(*std::min_element(all.begin(), all.end()) < max_norm);
}

// The tolerance of the equivalence tests: FlatAdam and LibTorch's Adam round differently by a
// few float ulps per step (tests/rl/flat_adam_test.cc), while each update moves the weights by
// about lr per step; the tests also check that the weights moved well beyond it.
constexpr double kMirrorTol = 1e-5;

}  // namespace bidex::test
