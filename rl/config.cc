#include "rl/config.h"

#include <cmath>
#include <cstdio>
#include <optional>

#include <yaml-cpp/yaml.h>

#include "core/error.h"
#include "core/yaml.h"
#include "rl/algorithms.h"
#include "rl/config_fields.h"
#include "sim/hand_spec.h"
#include "sim/physics.h"

namespace bidex::rl {

namespace {

bool takes_suite(const std::string& algo) {
  return find_algorithm(algo).trains_on == TrainsOn::kSuite;
}

std::string quoted(const std::string& s) {
  std::string q = "'";
  q.append(s).append("'");
  return q;
}

std::string map_keys(const YAML::Node& n) {
  std::string s;
  for (auto it = n.begin(); it != n.end(); ++it)
    s += (s.empty() ? "" : ", ") + it->first.as<std::string>();
  return s;
}

// Copies every key of `src` into `dst`, recursing into maps that both have.
void merge(YAML::Node dst, const YAML::Node& src, const std::string& file, const std::string& path) {
  for (auto it = src.begin(); it != src.end(); ++it) {
    const std::string key = it->first.as<std::string>();
    const std::string p = path.empty() ? key : path + "." + key;
    if (!dst[key])
      throw ConfigError(file, p, "a key of the defaults (" + map_keys(dst) + ")", quoted(key));
    if (it->second.IsMap() && dst[key].IsMap()) merge(dst[key], it->second, file, p);
    else dst[key] = YAML::Clone(it->second);
  }
}

// A value that is a bool or the one word `word` (value_norm's task, the switches' auto): the
// bool, or nullopt for the word; anything else fails naming `expected`.
std::optional<bool> bool_or_word(const YamlView& v, const std::string& word,
                                 const std::string& expected) {
  try {
    return v.as<bool>();
  } catch (const ConfigError&) {  // not a bool: the word, or an error naming the choices
  }
  std::string s;
  try {
    s = v.as<std::string>();
  } catch (const ConfigError&) {
  }
  if (s != word) v.fail(expected, v.repr());
  return std::nullopt;
}

// A setting of true, false or auto (`automatic`: decided by settle_auto for the learner's
// device, `value` false until then); absent: false.
void read_switch(const YamlView& parent, const char* key, bool& value, bool& automatic) {
  value = automatic = false;
  if (const auto v = parent.maybe(key)) {
    const auto b = bool_or_word(*v, "auto", "true, false or auto (on with a CUDA learner)");
    value = b.value_or(false);
    automatic = !b;
  }
}

}  // namespace

std::string default_train_config(const std::string& algo) {
  find_algorithm(algo);  // unknown: a ConfigError listing the known ones
  return sim::data_dir() + "/configs/train/" + algo + ".yaml";
}

std::string resolve_train_yaml(const std::string& file, const std::string& algo,
                               const std::string& target, const std::vector<std::string>& overrides,
                               const std::string& dataset) {
  const std::string& task = target;
  YamlView v = YamlView::load_file(file);
  v.expect_map();
  YAML::Node root = YAML::Clone(v.node());
  for (const char* k : {"task", "suite", "algo", "dataset"})
    if (root[k])
      throw ConfigError(file, k,
                        "no task, suite, algo or dataset key (they come from --task, --suite, "
                        "--algo and --dataset)",
                        "one");
  if (auto per = root["per_task"]) {
    if (!per.IsMap()) YamlView(per, file, "per_task").fail("a map of task id -> overrides", "another value");
    if (auto mine = per[task]) {
      root.remove("per_task");
      merge(root, mine, file, "per_task." + task);
    } else {
      root.remove("per_task");
    }
  }
  for (const std::string& o : overrides) {
    const size_t eq = o.find('=');
    std::string where = "-o ";
    where.append(o);
    if (eq == std::string::npos || eq == 0)
      throw ConfigError(where, "", "an override key.path=value (e.g. ppo.lr=1e-3)", quoted(o));
    const std::string key = o.substr(0, eq), value = o.substr(eq + 1);
    YAML::Node parsed;
    try {
      parsed = YAML::Load(value);
    } catch (const YAML::Exception& e) {
      throw ConfigError(where, key, "a YAML value", quoted(value) + " (" + e.msg + ")");
    }
    // walk the path; every level must exist in the defaults
    std::vector<std::string> parts;
    size_t start = 0;
    while (true) {
      const size_t dot = key.find('.', start);
      parts.push_back(key.substr(start, dot == std::string::npos ? std::string::npos : dot - start));
      if (dot == std::string::npos) break;
      start = dot + 1;
    }
    YAML::Node node = root;
    std::string path;
    for (size_t i = 0; i < parts.size(); ++i) {
      const std::string& k = parts[i];
      path += (path.empty() ? "" : ".") + k;
      if (k.empty() || !node.IsMap() || !node[k])
        throw ConfigError(where, path,
                          node.IsMap() ? "a known key (" + map_keys(node) + ")" : "a map above it",
                          quoted(k));
      if (i + 1 == parts.size()) {
        if (node[k].IsMap())
          throw ConfigError(where, path, "a key below it (" + map_keys(node[k]) + ")", "a section");
        node[k] = parsed;
      } else {
        node.reset(node[k]);
      }
    }
  }
  YAML::Node out;
  out[takes_suite(algo) ? "suite" : "task"] = target;
  out["algo"] = algo;
  if (!dataset.empty()) out["dataset"] = dataset;
  for (auto it = root.begin(); it != root.end(); ++it) out[it->first] = it->second;
  YAML::Emitter em;
  em.SetIndent(2);
  em << out;
  // validate now, so that a bad override fails before anything is written
  std::string text = std::string(em.c_str()) + "\n";
  parse_train_config(text, file);
  return text;
}

TrainConfig parse_train_config(const std::string& yaml_text, const std::string& name) {
  YamlView v = YamlView::load_string(yaml_text, name);
  TrainConfig c;
  c.algo = v.req<std::string>("algo");
  AlgorithmInfo info;
  try {
    info = find_algorithm(c.algo);
  } catch (const ConfigError&) {
    v.child("algo").fail("a known algorithm (" + algorithm_names() + ")", c.algo);
  }
  v.allow_keys({"task", "suite", "algo", "dataset", "seed", "env", "train", info.section});
  // an offline algorithm learns from a dataset of its task; no other algorithm takes one
  if (info.trains_on == TrainsOn::kDataset) {
    c.dataset = v.req<std::string>("dataset");
    if (c.dataset.empty())
      v.child("dataset").fail("a dataset folder (bidex collect; --dataset)", "\"\"");
  } else if (v.has("dataset")) {
    v.child("dataset").fail("no 'dataset' key for algorithm " + c.algo +
                                " (it learns from what it collects)",
                            v.child("dataset").repr());
  }
  // a task algorithm (ppo) trains on a task, a suite algorithm (mtppo) on a suite
  const bool suite_algo = takes_suite(c.algo);
  const char* want = suite_algo ? "suite" : "task";
  const char* other = suite_algo ? "task" : "suite";
  if (v.has(other))
    v.child(other).fail(std::string("no '") + other + "' key for algorithm " + c.algo + " (it trains on a " +
                            want + ")",
                        v.child(other).repr());
  (suite_algo ? c.suite : c.task) = v.req<std::string>(want);
  {
    auto s = v.child("seed");
    const double x = s.as<double>();
    if (x < 0 || x != std::floor(x) || x > 9.0e15) s.fail("an integer >= 0", s.repr());
    c.seed = static_cast<uint64_t>(x);
  }
  {
    auto e = v.child("env");
    e.allow_keys({"slots", "threads", "task_config", "physics"});
    c.slots = read_int(e, "slots", 1);
    c.threads = read_int(e, "threads", 0);
    c.task_config = sim::resolve_data_path(e.req<std::string>("task_config"));
    if (!c.suite.empty() && !c.task_config.empty())
      e.child("task_config").fail("\"\" for a suite run (each suite entry names its own task YAML)",
                                  e.child("task_config").repr());
    // absent from run configs written before the key existed: the default physics
    c.physics = e.has("physics") ? e.req<std::string>("physics") : "";
    // repository-relative paths work from any folder, so a run resumes and evaluates anywhere
    c.physics = sim::resolve_data_path(c.physics);
    if (!c.physics.empty()) {
      try {
        sim::load_physics(c.physics);
      } catch (const std::exception& ex) {
        e.child("physics").fail("a readable physics YAML (the keys of configs/sim/physics.yaml)",
                                e.child("physics").repr() + " (" + ex.what() + ")");
      }
    }
  }
  {
    auto t = v.child("train");
    t.allow_keys({"steps", "save_interval", "keep_checkpoints", "plot_interval", "device",
                  "torch_threads", "tf32"});
    auto s = t.child("steps");
    const double x = s.as<double>();
    if (!(x >= 1) || x != std::floor(x) || x > 9.0e15) s.fail("an integer >= 1", s.repr());
    c.steps = static_cast<int64_t>(x);
    c.save_interval = read_int(t, "save_interval", 1);
    c.keep_checkpoints = read_int(t, "keep_checkpoints", 1);
    c.plot_interval = read_int(t, "plot_interval", 1);
    c.device = read_choice(t, "device", {"auto", "cpu", "cuda"});
    c.torch_threads = read_int(t, "torch_threads", 0);
    if (auto tf = t.maybe("tf32")) c.tf32 = tf->as<bool>();
  }
  // a family registered from outside rl reads its own section
  if (const SectionReader* read = section_reader(c.algo)) {
    YamlView section = v.child(info.section);
    (*read)(section);
    YAML::Emitter em;
    em << section.node();
    c.section_yaml = std::string(em.c_str()) + "\n";
    return c;
  }
  // the keys every replay-buffer algorithm has (SacConfig, Td3Config), after allow_keys
  const std::vector<std::string> replay_keys = {
      "hidden", "activation", "horizon", "minibatches", "batch_size", "replay_size",
      "lr",     "gamma",      "polyak",  "max_grad_norm", "reward_scale"};
  auto replay_common = [&](const YamlView& p, auto& o) {
    o.hidden = read_widths(p.child("hidden"));
    o.activation = read_choice(p, "activation", {"elu", "relu", "tanh"});
    o.horizon = read_int(p, "horizon", 1);
    o.minibatches = read_int(p, "minibatches", 1);
    o.batch_size = read_int(p, "batch_size", 1);
    o.replay_size = read_int(p, "replay_size", 1);
    o.lr = read_real(p, "lr", 0, 1, true);
    o.gamma = read_real(p, "gamma", 0, 1, false);
    o.polyak = read_real(p, "polyak", 0, 1, false);
    o.max_grad_norm = read_real(p, "max_grad_norm", 0, 1e9, true);
    o.reward_scale = read_real(p, "reward_scale", 0, 1e6, true);
    if (o.replay_size < c.slots)
      p.child("replay_size").fail("at least env.slots (" + std::to_string(c.slots) +
                                  ") transitions, one step of every slot",
                                  std::to_string(o.replay_size));
  };
  if (info.section == "sac") {
    auto p = v.child("sac");
    std::vector<std::string> keys = replay_keys;
    keys.insert(keys.end(), {"init_alpha", "learn_alpha", "cuda_graph"});
    p.allow_keys(keys);
    auto& o = c.sac;
    replay_common(p, o);
    o.init_alpha = read_real(p, "init_alpha", 0, 1e3, true);
    o.learn_alpha = p.req<bool>("learn_alpha");
    if (auto g = p.maybe("cuda_graph")) o.cuda_graph = g->as<bool>();  // absent before it existed
    return c;
  }
  if (info.section == "td3" || info.section == "ddpg") {
    const bool td3 = info.section == "td3";
    auto p = v.child(info.section);
    std::vector<std::string> keys = replay_keys;
    keys.insert(keys.end(), {"epochs", "act_noise", "preact_l2", "cuda_graph"});
    if (td3) keys.insert(keys.end(), {"target_noise", "noise_clip", "policy_delay"});
    p.allow_keys(keys);
    auto& o = c.td3;
    replay_common(p, o);
    o.epochs = read_int(p, "epochs", 1);
    o.act_noise = read_real(p, "act_noise", 0, 10, false);
    // absent from run configs written before it existed: 0, the plain actor loss
    o.preact_l2 = p.has("preact_l2") ? read_real(p, "preact_l2", 0, 1e3, false) : 0.0;
    if (auto g = p.maybe("cuda_graph")) o.cuda_graph = g->as<bool>();  // absent before it existed
    o.twin = td3;
    if (td3) {
      o.target_noise = read_real(p, "target_noise", 0, 10, false);
      o.noise_clip = read_real(p, "noise_clip", 0, 10, false);
      o.policy_delay = read_int(p, "policy_delay", 1);
    } else {
      o.target_noise = 0;
      o.noise_clip = 0;
      o.policy_delay = 1;
    }
    return c;
  }
  {
    // the on-policy keys every section has, then PPO's surrogate or TRPO's step
    const bool trpo = info.section == "trpo";
    auto p = v.child(info.section);
    std::vector<std::string> keys = {"hidden", "activation", "init_std", "horizon", "epochs",
                                     "minibatches", "lr", "gamma", "lambda", "max_grad_norm",
                                     "value_coef", "obs_norm", "value_norm"};
    const std::vector<std::string> own =
        trpo ? std::vector<std::string>{"max_kl", "damping", "cg_iters", "backtracks",
                                        "accept_ratio", "step_fraction"}
             : std::vector<std::string>{"clip", "schedule", "desired_kl", "entropy_coef",
                                        "clip_value_loss", "value_clip", "cuda_graph",
                                        "act_graph", "bf16", "bf16_act", "align_widths",
                                        "fused_adam", "bias_grad_gemm", "advantage_norm"};
    keys.insert(keys.end(), own.begin(), own.end());
    p.allow_keys(keys);
    auto& o = c.ppo;
    o.hidden = read_widths(p.child("hidden"));
    o.activation = read_choice(p, "activation", {"elu", "relu", "tanh"});
    o.init_std = read_real(p, "init_std", 0, 10, true);
    o.horizon = read_int(p, "horizon", 1);
    o.epochs = read_int(p, "epochs", 1);
    o.minibatches = read_int(p, "minibatches", 1);
    o.lr = read_real(p, "lr", 0, 1, true);
    o.gamma = read_real(p, "gamma", 0, 1, false);
    o.lambda = read_real(p, "lambda", 0, 1, false);
    o.max_grad_norm = read_real(p, "max_grad_norm", 0, 1e9, true);
    o.value_coef = read_real(p, "value_coef", 0, 1e3, false);
    o.obs_norm = p.req<bool>("obs_norm");
    {
      const auto vn = p.child("value_norm");
      if (const auto b = bool_or_word(vn, "task", "true, false or task (multi-task PPO)")) {
        o.value_norm = *b;
      } else {
        if (c.algo != "mtppo")
          vn.fail("true or false (task normalises within each task of a suite's pack: --suite "
                  "with --algo mtppo; algorithm here: " + c.algo + ")",
                  vn.repr());
        o.value_norm = o.value_norm_task = true;
      }
    }
    if (trpo) {
      auto& t = c.trpo;
      t.max_kl = read_real(p, "max_kl", 0, 10, true);
      t.damping = read_real(p, "damping", 0, 1e3, false);
      t.cg_iters = read_int(p, "cg_iters", 1);
      t.backtracks = read_int(p, "backtracks", 1);
      t.accept_ratio = read_real(p, "accept_ratio", 0, 1, false);
      t.step_fraction = read_real(p, "step_fraction", 0, 1, true);
      o.schedule = "fixed";  // the critic's Adam
    } else {
      o.clip = read_real(p, "clip", 0, 1, true);
      o.schedule = read_choice(p, "schedule", {"adaptive", "fixed"});
      o.desired_kl = read_real(p, "desired_kl", 0, 10, true);
      o.entropy_coef = read_real(p, "entropy_coef", 0, 1e3, false);
      o.clip_value_loss = p.req<bool>("clip_value_loss");
      o.value_clip = read_real(p, "value_clip", 0, 1e3, true);
      if (auto g = p.maybe("cuda_graph")) o.cuda_graph = g->as<bool>();
      if (auto g = p.maybe("act_graph")) o.act_graph = g->as<bool>();  // absent before it existed
      // absent before they existed: off
      read_switch(p, "bf16", o.bf16, o.bf16_auto);
      read_switch(p, "bf16_act", o.bf16_act, o.bf16_act_auto);
      read_switch(p, "align_widths", o.align_widths, o.align_widths_auto);
      if (auto b = p.maybe("fused_adam")) o.fused_adam = b->as<bool>();      // the same
      if (auto b = p.maybe("bias_grad_gemm")) o.bias_grad_gemm = b->as<bool>();  // the same
      if (p.has("advantage_norm")) {  // absent from run configs written before it existed
        o.advantage_norm = read_choice(p, "advantage_norm", {"batch", "task"});
        if (o.advantage_norm == "task" && c.algo != "mtppo")
          p.child("advantage_norm")
              .fail("batch (task normalises within each task of a suite's pack: --suite with "
                    "--algo mtppo; algorithm here: " + c.algo + ")",
                    p.child("advantage_norm").repr());
      }
    }
  }
  if (c.batch() < c.ppo.minibatches) {
    std::string actual = std::to_string(c.batch());
    throw ConfigError(name, info.section + ".minibatches",
                      "at most env.slots x " + info.section + ".horizon (" + actual + ") minibatches",
                      std::to_string(c.ppo.minibatches));
  }
  return c;
}

std::string config_hash(const std::string& yaml_text) {
  uint64_t h = 1469598103934665603ull;  // FNV-1a, 64 bits
  for (unsigned char ch : yaml_text) {
    h ^= ch;
    h *= 1099511628211ull;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

void settle_auto(TrainConfig& c, bool cuda, std::string* yaml_text) {
  PpoConfig& o = c.ppo;
  const struct {
    const char* key;
    bool *value, *automatic;
  } settings[] = {{"bf16", &o.bf16, &o.bf16_auto},
                  {"bf16_act", &o.bf16_act, &o.bf16_act_auto},
                  {"align_widths", &o.align_widths, &o.align_widths_auto}};
  std::vector<const char*> settled;
  for (const auto& [key, value, automatic] : settings)
    if (*automatic) {
      *value = cuda;
      *automatic = false;
      settled.push_back(key);
    }
  if (!yaml_text || settled.empty()) return;
  YAML::Node root = YAML::Load(*yaml_text);
  const YAML::Node& view = root;  // const: looking a key up inserts nothing
  const std::string& name = find_algorithm(c.algo).section;
  if (!view[name] || !view[name].IsMap()) return;
  bool rewritten = false;
  for (const char* key : settled) {
    const YAML::Node was = view[name][key];
    if (was && was.IsScalar() && was.Scalar() == "auto") {
      root[name][key] = cuda;
      rewritten = true;
    }
  }
  if (!rewritten) return;
  YAML::Emitter em;  // as resolve_train_yaml writes it
  em.SetIndent(2);
  em << root;
  *yaml_text = std::string(em.c_str()) + "\n";
}

}  // namespace bidex::rl
