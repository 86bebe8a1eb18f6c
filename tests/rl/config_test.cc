// The training configuration: the paper's defaults, per-task columns, -o overrides and every
// kind of bad input, on the real configs/train/ppo.yaml.
#include "tests/rl/rl_fixture.h"

#include <dirent.h>

#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/yaml.h"
#include "metarl/algorithms.h"
#include "sim/physics.h"

using namespace bidex;

namespace {
rl::TrainConfig resolve(const std::string& task, const std::vector<std::string>& o = {}) {
  const std::string yaml = rl::resolve_train_yaml(rl::default_train_config("ppo"), "ppo", task, o);
  return rl::parse_train_config(yaml, "resolved");
}

template <class F>
void require_config_error(F&& f, const std::string& key, const std::string& expected_part,
                          const std::string& actual_part) {
  try {
    f();
    FAIL("no ConfigError");
  } catch (const ConfigError& e) {
    INFO(e.what());
    CHECK(e.key() == key);
    CHECK(e.expected().find(expected_part) != std::string::npos);
    CHECK(e.actual().find(actual_part) != std::string::npos);
  }
}
}  // namespace

TEST_CASE("PPO defaults are the paper's table", "[rl][config]") {
  const auto c = resolve("hand_over");
  CHECK(c.task == "hand_over");
  CHECK(c.algo == "ppo");
  CHECK(c.slots == 2048);
  CHECK(c.steps == 100000000);
  CHECK(c.ppo.hidden == std::vector<int>{1024, 1024, 512});
  CHECK(c.ppo.activation == "elu");
  CHECK(c.ppo.horizon == 8);
  CHECK(c.ppo.epochs == 5);
  CHECK(c.ppo.minibatches == 4);
  CHECK(c.ppo.clip == 0.2);
  CHECK(c.ppo.lr == 3e-4);
  CHECK(c.ppo.schedule == "adaptive");
  CHECK(c.ppo.desired_kl == 0.016);
  CHECK(c.ppo.gamma == 0.96);
  CHECK(c.ppo.lambda == 0.95);
  CHECK(c.ppo.max_grad_norm == 1.0);
  CHECK(c.ppo.entropy_coef == 0.0);
  CHECK(c.ppo.init_std == 0.8);
  CHECK(c.ppo.cuda_graph);  // bidex's own: replayed only on a CUDA device
  CHECK(c.batch() == 2048 * 8);
}

TEST_CASE("per-task columns of the paper's table and the sweep's apply to their task only", "[rl][config]") {
  const auto lift = resolve("lift_underarm");
  CHECK(lift.ppo.horizon == 20);
  CHECK(lift.ppo.epochs == 10);
  CHECK(lift.ppo.minibatches == 4);
  const auto stack = resolve("block_stack");
  CHECK(stack.ppo.epochs == 2);
  CHECK(stack.ppo.minibatches == 8);
  CHECK(stack.ppo.gamma == 0.9);
  CHECK(resolve("catch_underarm").ppo.epochs == 5);
  // the PPO sweep's measured settings: a quarter of its slot-steps an update
  for (const char* task : {"two_catch_underarm", "door_open_inward"}) {
    const auto c = resolve(task);
    CHECK(c.slots == 4096);
    CHECK(c.ppo.minibatches == 4);
    CHECK(c.batch() == 4096 * 8);
  }
  CHECK(resolve("door_open_outward").slots == 2048);
  // re_orientation's measured recipe: its training YAML (the progress term), a discount of 0.99,
  // a critic on normalised returns and 200M slot-steps
  const auto reo = resolve("re_orientation");
  CHECK(reo.ppo.gamma == 0.99);
  CHECK(reo.ppo.value_norm);
  CHECK(reo.steps == 200000000);
  const std::string aid = "tasks/re_orientation/re_orientation_progress.yaml";
  REQUIRE(reo.task_config.size() >= aid.size());
  CHECK(reo.task_config.substr(reo.task_config.size() - aid.size()) == aid);
  CHECK(std::ifstream(reo.task_config).good());
  CHECK(resolve("catch_underarm").task_config.empty());
  CHECK(resolve("catch_underarm").ppo.gamma == 0.96);
}

TEST_CASE("overrides (-o) change nested keys with YAML values", "[rl][config]") {
  const auto c = resolve("catch_underarm", {"ppo.lr=1e-3", "env.slots=64", "ppo.hidden=[8, 4]",
                                            "ppo.value_norm=true", "train.steps=2e6", "seed=7"});
  CHECK(c.ppo.lr == 1e-3);
  CHECK(c.slots == 64);
  CHECK(c.ppo.hidden == std::vector<int>{8, 4});
  CHECK(c.ppo.value_norm);
  CHECK(c.steps == 2000000);
  CHECK(c.seed == 7);
  CHECK_FALSE(resolve("catch_underarm", {"ppo.cuda_graph=false"}).ppo.cuda_graph);
  // an override wins over the per-task column
  CHECK(resolve("lift_underarm", {"ppo.horizon=3"}).ppo.horizon == 3);
}

// ppo.act_graph (rl/onpolicy.h), ppo.fused_adam (rl/flat_adam.h) and ppo.bias_grad_gemm
// (rl/policy.h): on in the shipped configs; a run's config written before a key existed, and
// TRPO, keep the step they had (act_graph is replayed only on a CUDA device, so on the CPU it is a
// parsed value)
TEST_CASE("ppo.act_graph, fused_adam and bias_grad_gemm: on in ppo.yaml and mtppo.yaml, off for "
          "configs without them and TRPO",
          "[rl][config]") {
  using Flag = bool rl::PpoConfig::*;
  const std::vector<std::pair<std::string, Flag>> keys = {
      {"act_graph", &rl::PpoConfig::act_graph},
      {"fused_adam", &rl::PpoConfig::fused_adam},
      {"bias_grad_gemm", &rl::PpoConfig::bias_grad_gemm}};
  const std::string mt =
      rl::resolve_train_yaml(rl::default_train_config("mtppo"), "mtppo", "MT4", {});
  const auto trpo = rl::parse_train_config(
      rl::resolve_train_yaml(rl::default_train_config("trpo"), "trpo", "hand_over", {}),
      "resolved");
  for (const auto& [key, flag] : keys) {
    INFO("ppo." << key);
    CHECK(resolve("hand_over").ppo.*flag);
    CHECK_FALSE(resolve("hand_over", {"ppo." + key + "=false"}).ppo.*flag);
    CHECK(rl::parse_train_config(mt, "resolved").ppo.*flag);
    std::string old =
        rl::resolve_train_yaml(rl::default_train_config("ppo"), "ppo", "hand_over", {});
    const auto at = old.find(key + ":");
    REQUIRE(at != std::string::npos);
    const auto line = old.rfind('\n', at) + 1;  // the key's whole line
    old.erase(line, old.find('\n', at) - line + 1);
    REQUIRE(old.find(key) == std::string::npos);
    const auto c = rl::parse_train_config(old, "run-config.yaml");
    CHECK_FALSE(c.ppo.*flag);
    CHECK(c.ppo.cuda_graph);  // the rest as before
    for (const auto& [other, other_flag] : keys)
      if (other != key) CHECK(c.ppo.*other_flag);
    CHECK_FALSE(trpo.ppo.*flag);
    require_config_error([&] { resolve("hand_over", {"ppo." + key + "=sometimes"}); },
                         "ppo." + key, "true or false", "sometimes");
  }
}

// ppo.bf16, bf16_act and align_widths (rl/autocast.h, rl/onpolicy.h, rl/policy.h): auto in
// ppo.yaml (on with a CUDA learner, decided by settle_auto, which rewrites the auto lines of a new
// run's config.yaml and nothing else), off in mtppo.yaml; true or false by override; off where a
// run's config predates them; not keys of TRPO's section
TEST_CASE("ppo.bf16, bf16_act and align_widths: auto in PPO, settled for the learner's device",
          "[rl][config]") {
  struct Switch {
    std::string key;
    bool rl::PpoConfig::*value;
    bool rl::PpoConfig::*automatic;
  };
  const std::vector<Switch> keys = {
      {"bf16", &rl::PpoConfig::bf16, &rl::PpoConfig::bf16_auto},
      {"bf16_act", &rl::PpoConfig::bf16_act, &rl::PpoConfig::bf16_act_auto},
      {"align_widths", &rl::PpoConfig::align_widths, &rl::PpoConfig::align_widths_auto}};
  const auto mt = [](std::vector<std::string> o) {
    return rl::parse_train_config(
        rl::resolve_train_yaml(rl::default_train_config("mtppo"), "mtppo", "MT4", o), "x.yaml");
  };
  const std::string yaml =
      rl::resolve_train_yaml(rl::default_train_config("ppo"), "ppo", "hand_over", {});
  for (const auto& k : keys) {
    INFO("ppo." << k.key);
    const auto c = resolve("hand_over");
    CHECK(c.ppo.*k.automatic);
    CHECK_FALSE(c.ppo.*k.value);  // undecided until settled
    REQUIRE(yaml.find("  " + k.key + ": auto\n") != std::string::npos);
    for (const bool cuda : {false, true}) {
      INFO("cuda " << cuda);
      rl::TrainConfig settled = c;
      std::string text = yaml;
      rl::settle_auto(settled, cuda, &text);
      CHECK(settled.ppo.*k.value == cuda);
      CHECK_FALSE(settled.ppo.*k.automatic);
      // the text says the same, and differs from the resolved one only there
      CHECK(text.find("  " + k.key + ": " + (cuda ? "true" : "false") + "\n") !=
            std::string::npos);
      const auto reread = rl::parse_train_config(text, "config.yaml");
      CHECK(reread.ppo.*k.value == cuda);
      CHECK_FALSE(reread.ppo.*k.automatic);
      std::string back = text;
      for (const auto& other : keys) {
        const std::string was = "  " + other.key + ": " + (cuda ? "true" : "false") + "\n";
        back.replace(back.find(was), was.size(), "  " + other.key + ": auto\n");
      }
      CHECK(back == yaml);
      // a settled text or an explicit value is left as it is
      std::string again = text;
      rl::settle_auto(settled, !cuda, &again);
      CHECK(again == text);
      CHECK(settled.ppo.*k.value == cuda);
    }
    CHECK(resolve("hand_over", {"ppo." + k.key + "=true"}).ppo.*k.value);
    CHECK_FALSE(resolve("hand_over", {"ppo." + k.key + "=true"}).ppo.*k.automatic);
    CHECK_FALSE(resolve("hand_over", {"ppo." + k.key + "=false"}).ppo.*k.value);
    CHECK_FALSE(mt({}).ppo.*k.value);
    CHECK_FALSE(mt({}).ppo.*k.automatic);
    CHECK(mt({"ppo." + k.key + "=true"}).ppo.*k.value);
    CHECK(mt({"ppo." + k.key + "=auto"}).ppo.*k.automatic);
    std::string old = yaml;  // a run's config from before the key existed
    const auto at = old.find(k.key + ":");
    const auto line = old.rfind('\n', at) + 1;
    old.erase(line, old.find('\n', at) - line + 1);
    const auto o = rl::parse_train_config(old, "run-config.yaml");
    CHECK_FALSE(o.ppo.*k.value);
    CHECK_FALSE(o.ppo.*k.automatic);
    require_config_error([&] { resolve("hand_over", {"ppo." + k.key + "=half"}); },
                         "ppo." + k.key, "true, false or auto", "half");
    require_config_error(
        [&] {
          rl::resolve_train_yaml(rl::default_train_config("trpo"), "trpo", "hand_over",
                                 {"trpo." + k.key + "=true"});
        },
        "trpo." + k.key, "a known key", k.key);
  }
  // a new CPU run's config.yaml: tests/rl/train_test.cc
}

TEST_CASE("bad overrides and bad values are ConfigErrors naming key, expected and actual",
          "[rl][config]") {
  const std::string file = rl::default_train_config("ppo");
  auto res = [&](std::vector<std::string> o) {
    return [=] { rl::resolve_train_yaml(file, "ppo", "hand_over", o); };
  };
  require_config_error(res({"ppo.lr"}), "", "key.path=value", "ppo.lr");
  require_config_error(res({"=3"}), "", "key.path=value", "=3");
  require_config_error(res({"ppo.learning_rate=1"}), "ppo.learning_rate", "desired_kl",
                       "learning_rate");
  require_config_error(res({"opt.lr=1"}), "opt", "a known key", "opt");
  require_config_error(res({"ppo=1"}), "ppo", "a key below it", "a section");
  require_config_error(res({"ppo.epochs=many"}), "ppo.epochs", "integer", "many");
  require_config_error(res({"ppo.gamma=1.5"}), "ppo.gamma", "[0, 1]", "1.5");
  require_config_error(res({"ppo.cuda_graph=sometimes"}), "ppo.cuda_graph", "true or false", "sometimes");
  require_config_error(res({"ppo.activation=swish"}), "ppo.activation", "elu", "swish");
  // advantages per task: multi-task PPO's key only (ppo.yaml has no such default), batch or task
  require_config_error(res({"ppo.advantage_norm=task"}), "ppo.advantage_norm", "a known key",
                       "advantage_norm");
  auto mt = [](std::vector<std::string> o) {
    return [=] {
      rl::resolve_train_yaml(rl::default_train_config("mtppo"), "mtppo", "MT4", o);
    };
  };
  require_config_error(mt({"ppo.advantage_norm=each"}), "ppo.advantage_norm", "task", "each");
  CHECK(rl::parse_train_config(rl::resolve_train_yaml(rl::default_train_config("mtppo"), "mtppo",
                                                      "MT4", {"ppo.advantage_norm=task"}),
                               "x.yaml")
            .ppo.advantage_norm == "task");
  // a run config written by hand for single-task PPO cannot ask for it either
  std::string y = rl::resolve_train_yaml(file, "ppo", "hand_over", {});
  const auto at = y.find("\nppo:\n");
  REQUIRE(at != std::string::npos);
  y.insert(at + 6, "  advantage_norm: task\n");
  require_config_error([=] { rl::parse_train_config(y, "x.yaml"); }, "ppo.advantage_norm", "mtppo",
                       "task");
  // returns normalised per task: multi-task PPO's value_norm: task; a bool elsewhere
  require_config_error(res({"ppo.value_norm=task"}), "ppo.value_norm", "mtppo", "task");
  require_config_error(res({"ppo.value_norm=maybe"}), "ppo.value_norm", "true, false or task",
                       "maybe");
  require_config_error(mt({"ppo.value_norm=each"}), "ppo.value_norm", "task", "each");
  {
    const auto c = rl::parse_train_config(
        rl::resolve_train_yaml(rl::default_train_config("mtppo"), "mtppo", "MT4",
                               {"ppo.value_norm=task"}),
        "x.yaml");
    CHECK(c.ppo.value_norm);
    CHECK(c.ppo.value_norm_task);
    const auto plain = rl::parse_train_config(
        rl::resolve_train_yaml(rl::default_train_config("mtppo"), "mtppo", "MT4",
                               {"ppo.value_norm=yes"}),
        "x.yaml");
    CHECK(plain.ppo.value_norm);  // yaml-cpp's other spellings of a bool still read
    CHECK_FALSE(plain.ppo.value_norm_task);
  }
  require_config_error(res({"ppo.hidden=[]"}), "ppo.hidden", "at least one", "[]");
  require_config_error(res({"train.device=tpu"}), "train.device", "cuda", "tpu");
  require_config_error(res({"env.slots=2", "ppo.horizon=1", "ppo.minibatches=4"}),
                       "ppo.minibatches", "at most", "4");
  require_config_error([] { rl::default_train_config("dqn"); }, "algo", "ppo", "dqn");
  require_config_error([] { resolve("hand_over", {"env.physics=no/such/physics.yaml"}); },
                       "env.physics", "physics YAML", "no/such/physics.yaml");
}

TEST_CASE("env.physics names the step a run trains and evaluates on", "[rl][config]") {
  CHECK(resolve("hand_over").physics.empty());  // configs/sim/physics.yaml
  const std::string file = sim::default_physics_path();
  CHECK(resolve("hand_over", {"env.physics=" + file}).physics == file);
  // a path relative to the repository is found from any working folder
  const std::string rel = "bench/results/physics-step/physics-discrete6.yaml";
  const std::string got = resolve("hand_over", {"env.physics=" + rel}).physics;
  CHECK(std::ifstream(got).good());
  CHECK(got.size() >= rel.size());
  CHECK(got.compare(got.size() - rel.size(), rel.size(), rel) == 0);
  // and so is a repository-relative task YAML
  CHECK(std::ifstream(resolve("hand_over", {"env.task_config=tasks/hand_over/hand_over.yaml"})
                          .task_config)
            .good());
  // a run config written before the key existed trains on the default physics
  std::string yaml = rl::resolve_train_yaml(rl::default_train_config("ppo"), "ppo", "hand_over", {});
  const auto at = yaml.find("physics:");
  REQUIRE(at != std::string::npos);
  yaml.erase(at, yaml.find('\n', at) - at);
  CHECK(rl::parse_train_config(yaml, "old run").physics.empty());
}

TEST_CASE("an unknown key in a training YAML file names the file", "[rl][config]") {
  test::TaskTempDir dir;
  std::string text = read_file(rl::default_train_config("ppo"));
  text = test::edit_once(text, "  epochs: 5\n", "  epochs: 5\n  epoch: 5\n");
  const std::string path = dir.write("ppo.yaml", text);
  try {
    rl::resolve_train_yaml(path, "ppo", "hand_over", {});
    FAIL("no ConfigError");
  } catch (const ConfigError& e) {
    INFO(e.what());
    CHECK(std::string(e.what()).find("ppo.epoch") != std::string::npos);
  }
}

TEST_CASE("TRPO defaults are the paper's table, in a trpo section of their own", "[rl][config]") {
  auto trpo = [](const std::string& task, const std::vector<std::string>& o = {}) {
    return rl::parse_train_config(
        rl::resolve_train_yaml(rl::default_train_config("trpo"), "trpo", task, o), "resolved");
  };
  const auto c = trpo("hand_over");
  CHECK(c.algo == "trpo");
  CHECK(c.ppo.hidden == std::vector<int>{1024, 1024, 512});
  CHECK(c.ppo.horizon == 8);
  CHECK(c.ppo.epochs == 5);
  CHECK(c.ppo.minibatches == 4);
  CHECK(c.ppo.lr == 1e-3);
  CHECK(c.ppo.gamma == 0.99);
  CHECK(c.ppo.lambda == 0.95);
  CHECK(c.ppo.init_std == 0.8);
  CHECK(c.ppo.max_grad_norm == 10.0);
  CHECK(c.trpo.damping == 0.1);
  CHECK(c.trpo.cg_iters == 3);
  CHECK(c.trpo.max_kl == 0.1);
  CHECK(c.trpo.backtracks == 10);
  CHECK(c.trpo.accept_ratio == 0.01);
  CHECK(c.trpo.step_fraction == 1.0);
  // the paper's lift column
  CHECK(trpo("lift_underarm").ppo.horizon == 20);
  CHECK(trpo("lift_underarm").ppo.epochs == 10);
  CHECK(trpo("hand_over", {"trpo.max_kl=0.02"}).trpo.max_kl == 0.02);
  // PPO's own keys are not TRPO's, and the ppo section is not there
  require_config_error([&] { trpo("hand_over", {"trpo.clip=0.1"}); }, "trpo.clip", "a known key",
                       "clip");
  require_config_error([&] { trpo("hand_over", {"ppo.lr=0.1"}); }, "ppo", "a known key", "ppo");
  require_config_error([&] { trpo("hand_over", {"trpo.max_kl=0"}); }, "trpo.max_kl", "(0", "0");
  require_config_error([&] { trpo("hand_over", {"trpo.cg_iters=0"}); }, "trpo.cg_iters", ">= 1",
                       "0");
}

namespace {
// The files of bench/sweep/ whose names end in `ext`, sorted.
std::vector<std::string> sweep_files(const std::string& ext) {
  const std::string dir = BIDEX_SOURCE_DIR "/bench/sweep";
  std::vector<std::string> out;
  DIR* d = ::opendir(dir.c_str());
  REQUIRE(d != nullptr);
  while (const dirent* e = ::readdir(d)) {
    const std::string name = e->d_name;
    if (name.size() > ext.size() && name.compare(name.size() - ext.size(), ext.size(), ext) == 0)
      out.push_back(dir + "/" + name);
  }
  ::closedir(d);
  std::sort(out.begin(), out.end());
  return out;
}
}  // namespace

// bench/sweep_run.sh names these files in a lease's run specs (cNAME, eNAME: a task YAML; oNAME:
// training overrides); a file that does not load fails its run on the GPU machine, minutes of
// the lease later, so every one is loaded here.
TEST_CASE("every sweep task YAML builds its task and every sweep overrides file resolves",
          "[rl][config]") {
  const std::vector<std::string> yamls = sweep_files(".yaml");
  REQUIRE(yamls.size() >= 16);
  for (const std::string& file : yamls) {
    INFO(file);
    // the task: an extends chain that ends at ../../tasks/<id>/<id>.yaml names it; one that ends
    // at a whole YAML in bench/sweep (a copy of a task's) must build some task
    std::string at = file, id;
    const std::string tasks_dir = BIDEX_SOURCE_DIR "/bench/sweep/../../tasks/";
    for (int depth = 0; id.empty() && depth < 4; ++depth) {
      const std::string text = read_file(at);
      const auto line = text.find("\nextends: ");
      if (line == std::string::npos) break;
      const auto begin = line + std::string("\nextends: ").size();
      at = path_beside(at, text.substr(begin, text.find('\n', begin) - begin));  // as core/yaml
      if (at.rfind(tasks_dir, 0) == 0)
        id = at.substr(tasks_dir.size(), at.find('/', tasks_dir.size()) - tasks_dir.size());
    }
    if (!id.empty()) {
      CHECK_NOTHROW(tasks::make_task(id, file));
      continue;
    }
    int built = 0;
    for (const auto& t : tasks::task_registry()) try {
        t.make(file);
        ++built;
      } catch (const ConfigError&) {
      }
    CHECK(built > 0);
  }
  // an overrides file is one override per line, as the sweep passes them (-o), after '#' comments;
  // it must resolve for at least one algorithm, on a task or a suite as the algorithm trains
  metarl::register_algorithms();  // MAML, ProMP and RL² (the bidex command registers them)
  const std::vector<std::string> overrides = sweep_files(".overrides");
  REQUIRE(overrides.size() >= 8);
  for (const std::string& file : overrides) {
    INFO(file);
    std::vector<std::string> lines;
    std::istringstream in(read_file(file));
    for (std::string line; std::getline(in, line);) {
      line = line.substr(0, line.find('#'));
      line.erase(0, line.find_first_not_of(" \t"));
      line.erase(line.find_last_not_of(" \t\r") + 1);
      if (!line.empty()) lines.push_back(line);
    }
    REQUIRE(!lines.empty());
    std::vector<std::string> accepted, errors;
    for (const rl::AlgorithmInfo& a : rl::algorithm_registry()) {
      if (a.trains_on == rl::TrainsOn::kDataset || a.multi_agent) continue;
      const std::string target = a.trains_on == rl::TrainsOn::kSuite ? (a.meta ? "ML4" : "MT4")
                                                                      : "hand_over";
      try {
        rl::parse_train_config(
            rl::resolve_train_yaml(rl::default_train_config(a.name), a.name, target, lines),
            file);
        accepted.push_back(a.name);
      } catch (const ConfigError& e) {
        errors.push_back(a.name + ": " + e.what());
      }
    }
    INFO("every algorithm refused it:\n" << [&] {
      std::string s;
      for (auto& e : errors) s += e + "\n";
      return s;
    }());
    CHECK(!accepted.empty());
  }
}
