// FlatAdam against LibTorch's Adam and clip_grad_norm_ on two copies of one actor-critic (13
// parameter tensors of several shapes): the same parameters and norms step after step, with the
// learning rate changing and the clip on and off; gradients accumulated in place in the flat
// buffer; parameters and gradients whose storage a module load, set_ or a set-to-none
// zero_grad replaced still optimised; the optimiser's state saved and loaded; and LibTorch Adam's
// saved state (the optimiser parts of older SAC, TD3, DDPG and TRPO checkpoints) loaded.
#include "tests/rl/rl_fixture.h"
#include "tests/rl/mirror_fixture.h"

#include <cstdint>
#include <sstream>

#include "rl/flat_adam.h"
#include "rl/policy.h"

using namespace bidex;

namespace {

rl::ActorCritic make_net(uint64_t seed) {
  rl::PpoConfig c;
  c.hidden = {16, 8};
  c.obs_norm = false;
  torch::manual_seed(seed);
  return rl::ActorCritic(5, 3, c);
}

// One batch and a loss that reaches every parameter; `scale` sets the gradient's norm.
struct Batch {
  torch::Tensor x, y;
  double scale;
};

Batch batch(int k, double scale) {
  torch::manual_seed(100 + k);
  return {torch::randn({32, 5}), torch::randn({32, 3}), scale};
}

torch::Tensor loss_of(rl::ActorCritic& m, const Batch& b) {
  return b.scale * ((m->mean(b.x) - b.y).pow(2).mean() + (m->value(b.x) - 1.0).pow(2).mean() +
                    m->log_std().pow(2).sum());
}

// The reference: LibTorch's Adam at learning rate `lr` after clip_grad_norm_; returns the norm.
double reference_step(rl::ActorCritic& m, torch::optim::Adam& opt, const Batch& b, double lr,
                      double max_norm) {
  for (auto& g : opt.param_groups()) static_cast<torch::optim::AdamOptions&>(g.options()).lr(lr);
  opt.zero_grad();
  loss_of(m, b).backward();
  const double norm = torch::nn::utils::clip_grad_norm_(m->parameters(), max_norm);
  opt.step();
  return norm;
}

double flat_step(rl::ActorCritic& m, rl::FlatAdam& opt, const Batch& b, double lr,
                 double max_norm) {
  opt.set_lr(lr);
  opt.zero_grad();
  loss_of(m, b).backward();
  const auto norm = opt.clip_grad_norm(max_norm);
  opt.step();
  return norm.item<double>();
}

// Parameters compare with test::max_param_diff. The two optimisers round differently (one norm
// of the flat gradient against a norm of norms; a division and a product against addcdiv_), by
// a few float ulps of the O(1) weights, while a step moves them by about lr (1e-3 to 1e-2): a
// bound of 1e-6 tells the two apart from any error of the update.

// The step's learning rate and clip: the clip binds on even steps (large loss, max_norm 0.5),
// never on odd ones (tiny loss, max_norm 1e3).
double lr_at(int k) { return 1e-2 * (1 + k % 3) / 2; }
double max_norm_at(int k) { return k % 2 == 0 ? 0.5 : 1e3; }
Batch batch_at(int k) { return batch(k, k % 2 == 0 ? 10.0 : 1e-3); }

}  // namespace

TEST_CASE("FlatAdam steps as LibTorch's Adam after clip_grad_norm_", "[rl][ppo][flat_adam]") {
  auto ref = make_net(1), flat = make_net(1);
  torch::optim::Adam ref_opt(ref->parameters(), torch::optim::AdamOptions(1e-3));
  rl::FlatAdam opt(flat->parameters(), 1e-3);
  REQUIRE(flat->parameters().size() == 13);
  CHECK(test::max_param_diff(*flat, *ref) == 0);  // moving into the flat buffer keeps the values
  for (int k = 0; k < 12; ++k) {
    const auto b = batch_at(k);
    const double want = reference_step(ref, ref_opt, b, lr_at(k), max_norm_at(k));
    // both regimes of the clip happen
    if (k % 2 == 0) REQUIRE(want > max_norm_at(k));
    else REQUIRE(want < max_norm_at(k));
    // autograd accumulates into the gradients bound after zero_grad(), one after another, each
    // from the next multiple of kAlign floats
    opt.set_lr(lr_at(k));
    opt.zero_grad();
    auto params = flat->parameters();
    std::vector<void*> bound;
    for (auto& p : params) bound.push_back(p.grad().data_ptr());
    const int64_t align = rl::FlatAdam::kAlign * sizeof(float);
    for (size_t j = 1; j < params.size(); ++j) {
      const int64_t end = params[j - 1].numel() * sizeof(float);
      REQUIRE(static_cast<char*>(bound[j]) ==
              static_cast<char*>(bound[j - 1]) + (end + align - 1) / align * align);
    }
    loss_of(flat, b).backward();
    for (size_t j = 0; j < params.size(); ++j) REQUIRE(params[j].grad().data_ptr() == bound[j]);
    const double got = opt.clip_grad_norm(max_norm_at(k)).item<double>();
    opt.step();
    CHECK(got == Approx(want).epsilon(1e-6));
    INFO("step " << k);
    CHECK(test::max_param_diff(*flat, *ref) < 1e-6);
  }
  CHECK(opt.steps() == 12);
  CHECK(opt.lr() == lr_at(11));
}

TEST_CASE("FlatAdam follows parameters and gradients whose storage was replaced",
          "[rl][ppo][flat_adam]") {
  auto ref = make_net(1), flat = make_net(1);
  torch::optim::Adam ref_opt(ref->parameters(), torch::optim::AdamOptions(1e-3));
  rl::FlatAdam opt(flat->parameters(), 1e-3);
  int k = 0;
  auto both = [&](int steps) {
    for (int end = k + steps; k < end; ++k) {
      const auto b = batch_at(k);
      const double want = reference_step(ref, ref_opt, b, lr_at(k), max_norm_at(k));
      CHECK(flat_step(flat, opt, b, lr_at(k), max_norm_at(k)) == Approx(want).epsilon(1e-6));
      INFO("step " << k);
      CHECK(test::max_param_diff(*flat, *ref) < 1e-6);
    }
  };
  both(3);
  // Module::load gives every parameter the archive's storage (tensor.set_): another network's
  // values, loaded into both; LibTorch's Adam keeps its moments across it, as FlatAdam must
  {
    auto other = make_net(7);
    torch::serialize::OutputArchive out;
    other->save(out);
    std::ostringstream bytes;
    out.save_to(bytes);
    const void* before = flat->parameters()[0].data_ptr();
    for (auto* net : {&ref, &flat}) {
      torch::serialize::InputArchive in;
      std::istringstream is(bytes.str());
      in.load_from(is);
      (*net)->load(in);
    }
    REQUIRE(flat->parameters()[0].data_ptr() != before);
    REQUIRE(test::max_param_diff(*flat, *other) == 0);
  }
  both(3);
  // set_ on one parameter, and gradients undefined after zero_grad() (LibTorch 2's
  // Module::zero_grad), so that backward allocates fresh ones
  {
    torch::NoGradGuard ng;
    const auto values = torch::randn({3});
    ref->log_std().set_(values.clone());
    flat->log_std().set_(values.clone());
  }
  const auto b = batch_at(k);
  const double want = reference_step(ref, ref_opt, b, lr_at(k), max_norm_at(k));
  opt.set_lr(lr_at(k));
  opt.zero_grad();
  flat->zero_grad(/*set_to_none=*/true);
  loss_of(flat, b).backward();
  CHECK(opt.clip_grad_norm(max_norm_at(k)).item<double>() == Approx(want).epsilon(1e-6));
  opt.step();
  CHECK(test::max_param_diff(*flat, *ref) < 1e-6);
  ++k;
  both(3);
}

TEST_CASE("FlatAdam's saved state continues the run, and a state of other sizes is refused",
          "[rl][ppo][flat_adam]") {
  auto a = make_net(1);
  rl::FlatAdam opt_a(a->parameters(), 1e-3);
  for (int k = 0; k < 4; ++k) flat_step(a, opt_a, batch_at(k), lr_at(k), max_norm_at(k));
  torch::serialize::OutputArchive out;
  a->save(out);
  opt_a.save(out);
  std::ostringstream bytes;
  out.save_to(bytes);
  auto archive = [&] {
    torch::serialize::InputArchive in;
    std::istringstream is(bytes.str());
    in.load_from(is);
    return in;
  };
  // b loads the network and the optimiser; `fresh` the network only (Adam's state anew)
  auto b = make_net(2), fresh = make_net(3);
  rl::FlatAdam opt_b(b->parameters(), 1.0), opt_fresh(fresh->parameters(), lr_at(3));
  {
    auto in = archive();
    b->load(in);
    opt_b.load(in);
    auto in_fresh = archive();
    fresh->load(in_fresh);
  }
  CHECK(opt_b.steps() == 4);
  CHECK(opt_b.lr() == lr_at(3));
  for (int k = 4; k < 8; ++k) {
    // each keeps the learning rate it has: b the one it loaded
    auto step = [&](rl::ActorCritic& net, rl::FlatAdam& opt) {
      opt.zero_grad();
      loss_of(net, batch_at(k)).backward();
      opt.clip_grad_norm(max_norm_at(k));
      opt.step();
    };
    step(a, opt_a);
    step(b, opt_b);
    step(fresh, opt_fresh);
  }
  CHECK(test::max_param_diff(*b, *a) == 0);
  CHECK(test::max_param_diff(*fresh, *a) > 1e-3);  // the moments and the step count matter
  // the state of a network of other widths: an error naming both sizes
  rl::PpoConfig c;
  c.hidden = {16, 9};
  rl::ActorCritic wide(5, 3, c);
  rl::FlatAdam opt_wide(wide->parameters(), 1e-3);
  int64_t saved = 0, here = 0;
  for (auto& p : a->parameters()) saved += p.numel();
  for (auto& p : wide->parameters()) here += p.numel();
  auto in = archive();
  try {
    opt_wide.load(in);
    FAIL("no error");
  } catch (const c10::Error& e) {
    const std::string msg = e.what();
    INFO(msg);
    CHECK(msg.find("[" + std::to_string(saved) + "]") != std::string::npos);
    CHECK(msg.find("[" + std::to_string(here) + "]") != std::string::npos);
  }
}

TEST_CASE("FlatAdam loads LibTorch Adam's saved state and steps on as that Adam would",
          "[rl][flat_adam]") {
  // the optimiser part of checkpoints written before SAC, TD3, DDPG and TRPO moved to FlatAdam
  auto bytes_of = [](const torch::optim::Adam& opt) {
    torch::serialize::OutputArchive out;
    opt.save(out);
    std::ostringstream bytes;
    out.save_to(bytes);
    return bytes.str();
  };
  auto archive = [](const std::string& bytes) {
    torch::serialize::InputArchive in;
    std::istringstream is(bytes);
    in.load_from(is);
    return in;
  };
  auto ref = make_net(1);
  torch::optim::Adam ref_opt(ref->parameters(), torch::optim::AdamOptions(1e-3));
  const std::string unstepped = bytes_of(ref_opt);
  for (int k = 0; k < 4; ++k) reference_step(ref, ref_opt, batch_at(k), lr_at(k), max_norm_at(k));
  const std::string stepped = bytes_of(ref_opt);
  // flat and fresh: ref's weights now; flat has stepped elsewhere before it loads
  auto flat = make_net(2), fresh = make_net(3);
  rl::FlatAdam opt(flat->parameters(), 0.5), opt_fresh(fresh->parameters(), 1e-3);
  for (int k = 0; k < 2; ++k) flat_step(flat, opt, batch_at(k), lr_at(k), max_norm_at(k));
  opt.set_lr(0.5);
  {
    torch::NoGradGuard ng;
    for (auto* net : {&flat, &fresh}) {
      auto dst = (*net)->parameters();
      auto src = ref->parameters();
      for (size_t j = 0; j < dst.size(); ++j) dst[j].copy_(src[j]);
    }
  }
  // an Adam that never stepped has no state: FlatAdam's is then a fresh one, rate kept
  {
    auto in = archive(unstepped);
    opt.load(in);
  }
  CHECK(opt.steps() == 0);
  CHECK(opt.lr() == 0.5);
  {
    auto in = archive(stepped);
    opt.load(in);
  }
  CHECK(opt.steps() == 4);
  CHECK(opt.lr() == 0.5);  // LibTorch's Adam::load keeps the rate too
  for (int k = 4; k < 8; ++k) {
    const double want = reference_step(ref, ref_opt, batch_at(k), lr_at(k), max_norm_at(k));
    CHECK(flat_step(flat, opt, batch_at(k), lr_at(k), max_norm_at(k)) ==
          Approx(want).epsilon(1e-6));
    flat_step(fresh, opt_fresh, batch_at(k), lr_at(k), max_norm_at(k));
    INFO("step " << k);
    CHECK(test::max_param_diff(*flat, *ref) < 1e-6);
  }
  CHECK(test::max_param_diff(*fresh, *ref) > 1e-3);  // the loaded moments and count mattered
  // LibTorch Adam state of other parameters, and an archive of neither kind: errors saying so
  rl::PpoConfig c;
  c.hidden = {16, 9};
  rl::ActorCritic wide(5, 3, c);
  rl::FlatAdam opt_wide(wide->parameters(), 1e-3);
  torch::nn::Linear lin(2, 2);
  rl::FlatAdam opt_lin(lin->parameters(), 1e-3);
  torch::serialize::OutputArchive module_out;
  lin->save(module_out);
  std::ostringstream module_bytes;
  module_out.save_to(module_bytes);
  for (auto [o, bytes, expected] :
       {std::tuple{&opt_wide, stepped,
                   "have shapes [8, 16] and [8, 16], the parameter [9, 16]"},
        std::tuple{&opt_lin, stepped, "LibTorch Adam state is of 13 parameters, this "
                                      "optimiser's of 2"},
        std::tuple{&opt_lin, module_bytes.str(), "neither FlatAdam's"}}) {
    INFO(expected);
    auto in = archive(bytes);
    try {
      o->load(in);
      FAIL("loaded");
    } catch (const c10::Error& e) {
      CHECK_THAT(e.what(), Catch::Contains(expected));
    }
  }
}

// The fused step (LibTorch 2.4 on) against the plain one on two copies of one network: the same
// parameters and norms within float rounding, the clip binding on even steps, and the gradients
// autograd's own tensors after a zero_grad() that undefined them. Where this LibTorch has no
// fused step (Debian 12's 1.13), asking for one gives the plain step, bit for bit.
TEST_CASE("FlatAdam's fused step equals its plain step, or is the plain step where LibTorch "
          "lacks it",
          "[rl][ppo][flat_adam]") {
  auto plain_net = make_net(3), fused_net = make_net(3);
  rl::FlatAdam plain(plain_net->parameters(), 1e-3);
  rl::FlatAdam fused(fused_net->parameters(), 1e-3, 0.9, 0.999, 1e-8, /*fused=*/true);
  CHECK_FALSE(plain.fused());
  CHECK(fused.fused() == rl::FlatAdam::fused_available());
  if (!fused.fused()) WARN("this LibTorch has no fused Adam: the fallback is checked");
  for (int k = 0; k < 12; ++k) {
    INFO("step " << k);
    const auto b = batch_at(k);
    const double want = flat_step(plain_net, plain, b, lr_at(k), max_norm_at(k));
    if (k % 2 == 0) REQUIRE(want > max_norm_at(k));
    fused.set_lr(lr_at(k));
    fused.zero_grad();
    for (const auto& p : fused_net->parameters())
      CHECK(p.grad().defined() == !fused.fused());  // fused: undefined until backward
    loss_of(fused_net, b).backward();
    const double got = fused.clip_grad_norm(max_norm_at(k)).item<double>();
    fused.step();
    const auto pf = fused_net->parameters(), pp = plain_net->parameters();
    if (fused.fused()) {
      CHECK(got == Approx(want).epsilon(1e-6));
      CHECK(test::max_param_diff(*fused_net, *plain_net) < 1e-6);
      for (size_t j = 0; j < pf.size(); ++j)  // the clipped gradients, as the plain clip's
        CHECK(torch::allclose(pf[j].grad(), pp[j].grad(), 1e-5, 1e-7));
    } else {
      for (size_t j = 0; j < pf.size(); ++j) CHECK(torch::equal(pf[j].grad(), pp[j].grad()));
      CHECK(got == want);
      CHECK(test::max_param_diff(*fused_net, *plain_net) == 0);
    }
  }
  CHECK(fused.steps() == 12);
  // the steps moved the weights far beyond the bound above
  auto fresh = make_net(3);
  CHECK(test::max_param_diff(*fused_net, *fresh) > 1e-3);
}

// keep_copy(): the values in bfloat16, equal to the parameters cast, after every plain or fused
// step, after a rebind of parameters whose storage was replaced, and after refresh_copy() of
// parameters written in place; copy_of() finds a parameter's place in it, and weight_copy()
// finds it through the innermost live CopyScope only.
TEST_CASE("FlatAdam's bfloat16 copy follows the values", "[rl][ppo][flat_adam]") {
  const auto bf16 = torch::kBFloat16;
  auto copies_equal = [&](rl::ActorCritic& net, const rl::FlatAdam& opt) {
    bool same = true;
    for (const auto& p : net->parameters()) {
      const auto c = opt.copy_of(p, bf16);
      same = same && c.defined() && c.sizes() == p.sizes() && torch::equal(c, p.to(bf16));
    }
    return same;
  };
  for (bool fused : {false, true}) {
    INFO("fused " << fused);
    auto net = make_net(3);
    rl::FlatAdam opt(net->parameters(), 1e-2, 0.9, 0.999, 1e-8, fused);
    const auto p0 = net->parameters()[0];
    CHECK_FALSE(opt.copy_of(p0, bf16).defined());  // none kept yet
    opt.keep_copy(bf16);
    CHECK(copies_equal(net, opt));
    CHECK_FALSE(opt.copy_of(p0, torch::kHalf).defined());           // not of that type
    CHECK_FALSE(opt.copy_of(p0.detach().clone(), bf16).defined());  // not a parameter
    for (int k = 0; k < 3; ++k) {
      flat_step(net, opt, batch_at(k), lr_at(k), max_norm_at(k));
      INFO("step " << k);
      CHECK(copies_equal(net, opt));
    }
    CHECK(test::max_param_diff(*net, *make_net(3)) > 1e-3);  // the steps moved the weights
    // a parameter's storage replaced (as Module::load does): no place until the rebind
    auto p = net->parameters()[1];
    {
      torch::NoGradGuard ng;
      p.set_(p.detach().clone() + 0.5);
    }
    CHECK_FALSE(opt.copy_of(p, bf16).defined());
    opt.rebind();
    CHECK(copies_equal(net, opt));
    // parameters written in place: the copy is stale until refresh_copy()
    {
      torch::NoGradGuard ng;
      for (auto& q : net->parameters()) q.add_(0.25);
    }
    CHECK_FALSE(copies_equal(net, opt));
    opt.refresh_copy();
    CHECK(copies_equal(net, opt));
  }
  // every parameter's place, in the values and in the copy, 16-byte aligned and kAlign elements
  // from the first place: log_std's 3 values come first, which would leave every later bfloat16
  // weight 6 bytes off
  {
    auto net = make_net(6);
    rl::FlatAdam opt(net->parameters(), 1e-3);
    opt.keep_copy(bf16);
    const auto params = net->parameters();
    REQUIRE(params[0].numel() == 3);
    auto at = [](const torch::Tensor& t) { return reinterpret_cast<std::uintptr_t>(t.data_ptr()); };
    const auto base = at(params[0]), copy_base = at(opt.copy_of(params[0], bf16));
    for (const auto& p : params) {
      const auto c = opt.copy_of(p, bf16);
      CHECK(at(p) % 16 == 0);
      CHECK(at(c) % 16 == 0);
      CHECK((at(p) - base) % (rl::FlatAdam::kAlign * sizeof(float)) == 0);
      CHECK((at(c) - copy_base) % (rl::FlatAdam::kAlign * 2) == 0);
    }
    // the saved moments hold the parameters without the gaps, as before the places were aligned
    auto in = test::saved_state(opt);
    torch::Tensor saved;
    in.read("exp_avg", saved);
    int64_t total = 0;
    for (const auto& p : params) total += p.numel();
    CHECK(saved.numel() == total);
  }
  // the scopes: weight_copy() asks the innermost live one
  auto a_net = make_net(4), b_net = make_net(5);
  rl::FlatAdam a(a_net->parameters(), 1e-3), b(b_net->parameters(), 1e-3);
  a.keep_copy(bf16);
  b.keep_copy(bf16);
  const auto pa = a_net->parameters()[0], pb = b_net->parameters()[0];
  CHECK_FALSE(rl::FlatAdam::weight_copy(pa, bf16).defined());
  {
    rl::FlatAdam::CopyScope outer(a);
    CHECK(rl::FlatAdam::weight_copy(pa, bf16).data_ptr() == a.copy_of(pa, bf16).data_ptr());
    CHECK_FALSE(rl::FlatAdam::weight_copy(pb, bf16).defined());
    {
      rl::FlatAdam::CopyScope inner(b);
      CHECK(rl::FlatAdam::weight_copy(pb, bf16).data_ptr() == b.copy_of(pb, bf16).data_ptr());
      CHECK_FALSE(rl::FlatAdam::weight_copy(pa, bf16).defined());
    }
    CHECK(rl::FlatAdam::weight_copy(pa, bf16).data_ptr() == a.copy_of(pa, bf16).data_ptr());
  }
  CHECK_FALSE(rl::FlatAdam::weight_copy(pa, bf16).defined());
}
