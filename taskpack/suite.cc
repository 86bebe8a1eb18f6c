#include "taskpack/suite.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>

#include <unistd.h>

#include "core/error.h"
#include "core/yaml.h"
#include "sim/hand_spec.h"
#include "tasks/registry.h"

namespace bidex::taskpack {

std::vector<std::string> known_suites() {
  return {"MT1", "ML1", "MT4", "ML4", "MT20", "ML20", "ML1-goals", "ML1-raise-goals"};
}

namespace {

// 'text' (built with append: GCC 12's -Wrestrict misfires on "'" + std::string)
std::string quoted(const std::string& s) {
  std::string q = "'";
  q.append(s).append("'");
  return q;
}

std::string suites_dir() { return sim::data_dir() + "/configs/suites"; }

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) {
    if (!out.empty()) out.append(", ");
    out.append(s);
  }
  return out;
}

// Uniform in [-1, 1) from the stream's top 53 bits: the same goals on every platform.
double uniform_pm1(std::mt19937_64& rng) {
  return 2.0 * static_cast<double>(rng() >> 11) * 0x1.0p-53 - 1.0;
}

// An entry's `goals: {count, half_extent}`, drawn from `rng` (the suite's goal stream).
std::vector<std::array<double, 3>> read_goals(const YamlView& v, const std::string& task,
                                              std::mt19937_64& rng) {
  v.allow_keys({"count", "half_extent"});
  if (tasks::find_task(task).spec().goal_shifts == 0)
    v.fail("no goals (task " + task + " takes no per-slot goal)", v.repr());
  const YamlView c = v.child("count");
  const int count = c.as<int>();
  if (count < 1) c.fail("a goal count >= 1", c.repr());
  const YamlView h = v.child("half_extent");
  const auto half = h.as<std::array<double, 3>>();
  for (double x : half)
    if (x < 0) h.fail("3 half extents >= 0 in metres [x, y, z]", h.repr());
  std::vector<std::array<double, 3>> goals(count);
  for (auto& g : goals)
    for (int k = 0; k < 3; ++k) g[k] = half[k] * uniform_pm1(rng);
  return goals;
}

// One entry of a split: {task, label?, config?, reward_scale?, goals?}.
SuiteEntry read_entry(const YamlView& v, const std::string& suite_file,
                      std::optional<std::mt19937_64>& goal_rng) {
  v.allow_keys({"task", "label", "config", "reward_scale", "goals"});
  SuiteEntry e;
  {
    const YamlView t = v.child("task");
    e.task = t.as<std::string>();
    try {
      tasks::find_task(e.task);
    } catch (const ConfigError& err) {
      t.fail(err.expected(), err.actual());
    }
  }
  e.label = e.task;
  if (auto l = v.maybe("label")) {
    e.label = l->as<std::string>();
    if (e.label.empty()) l->fail("a non-empty label", "an empty string");
  }
  if (auto c = v.maybe("config")) {
    const std::string rel = c->as<std::string>();
    e.config = path_beside(suite_file, rel);
    if (rel.empty() || ::access(e.config.c_str(), R_OK) != 0)
      c->fail("a readable task YAML (relative to the suite file's folder)",
              quoted(rel).append(" (").append(e.config).append(" cannot be read)"));
  }
  if (auto r = v.maybe("reward_scale")) {
    e.reward_scale = r->as<double>();  // finite, or a ConfigError
    if (e.reward_scale < 0) r->fail("a reward scale >= 0", r->repr());
  }
  if (auto g = v.maybe("goals")) {
    if (!goal_rng) g->fail("a goal_seed at the suite's top level first", "goals without it");
    e.goals = read_goals(*g, e.task, *goal_rng);
  }
  return e;
}

std::vector<SuiteEntry> read_split(const YamlView& v, const std::string& suite_file,
                                   std::optional<std::mt19937_64>& goal_rng) {
  if (!v.is_seq() || v.node().size() == 0) v.fail("a non-empty list of task entries", v.repr());
  std::vector<SuiteEntry> out;
  for (const auto& it : v.items()) out.push_back(read_entry(it, suite_file, goal_rng));
  return out;
}

}  // namespace

Suite load_suite(const std::string& id_or_file) {
  const bool by_id = id_or_file.find('/') == std::string::npos &&
                     !(id_or_file.size() > 5 &&
                       id_or_file.compare(id_or_file.size() - 5, 5, ".yaml") == 0);
  std::string file = id_or_file;
  if (by_id) {
    const auto ids = known_suites();
    if (std::find(ids.begin(), ids.end(), id_or_file) == ids.end())
      throw ConfigError("", "suite", std::string("a suite id (").append(join(ids)).append(") or the path of a suite YAML"),
                        quoted(id_or_file));
    file = suites_dir() + "/" + id_or_file + ".yaml";
  }
  const YamlView root = YamlView::load_file(file);
  root.allow_keys({"id", "description", "mode", "source", "goal_seed", "train", "test"});
  Suite s;
  s.file = file;
  {
    const YamlView v = root.child("id");
    s.id = v.as<std::string>();
    if (s.id.empty()) v.fail("a suite id", "an empty string");
    if (by_id && s.id != id_or_file) v.fail(std::string("the id of the file's name, ").append(quoted(id_or_file)), v.repr());
  }
  s.description = root.req<std::string>("description");
  s.source = root.req<std::string>("source");
  {
    const YamlView v = root.child("mode");
    const std::string m = v.as<std::string>();
    if (m == "multitask")
      s.mode = PackMode::kMultiTask;
    else if (m == "meta")
      s.mode = PackMode::kMeta;
    else
      v.fail("multitask or meta", v.repr());
  }
  std::optional<std::mt19937_64> goal_rng;
  if (auto g = root.maybe("goal_seed")) {
    const int seed = g->as<int>();
    if (seed < 0) g->fail("a seed >= 0", g->repr());
    s.goal_seed = static_cast<uint64_t>(seed);
    goal_rng.emplace(s.goal_seed);
  }
  s.train = read_split(root.child("train"), file, goal_rng);
  {
    const YamlView v = root.child("test");
    if (v.node().IsScalar() && v.node().as<std::string>() == "train") {
      s.test = s.train;
      s.test_is_train = true;
    } else if (s.mode == PackMode::kMultiTask) {
      // the one-hot id of a slot is its train entry's index: a multi-task suite is tested on
      // exactly its train entries
      v.fail("'train' (a multitask suite is tested on its train entries)", v.repr());
    } else {
      s.test = read_split(v, file, goal_rng);
    }
  }
  // labels are unique within the suite (a test list may not reuse a train label)
  std::vector<std::string> seen;
  auto check = [&](const std::vector<SuiteEntry>& list, const char* split) {
    for (size_t i = 0; i < list.size(); ++i) {
      if (std::find(seen.begin(), seen.end(), list[i].label) != seen.end())
        root.child(split).items()[i].fail(
            "a label unlike every other entry's (set `label` to tell entries apart)",
            quoted(list[i].label).append(" a second time"));
      seen.push_back(list[i].label);
    }
  };
  check(s.train, "train");
  if (!(root.child("test").node().IsScalar())) check(s.test, "test");
  return s;
}

PackSpec suite_pack(const Suite& suite, const std::string& split, int total_slots) {
  if (split != "train" && split != "test")
    throw ConfigError(suite.file, "split", "train or test", quoted(split));
  const auto& list = split == "train" ? suite.train : suite.test;
  const int n = static_cast<int>(list.size());
  if (n == 0) throw ConfigError(suite.file, split, "at least one entry", "none");
  if (total_slots < n)
    throw ConfigError(suite.file, "total_slots",
                      "at least one slot per " + split + " entry (" + std::to_string(n) + ")",
                      std::to_string(total_slots));
  PackSpec p;
  p.name = suite.id + "/" + split;
  p.mode = suite.mode;
  for (int i = 0; i < n; ++i) {
    const SuiteEntry& e = list[i];
    PackEntry pe;
    pe.task = e.task;
    pe.label = e.label;
    pe.config = e.config;
    pe.slots = total_slots / n + (i < total_slots % n ? 1 : 0);
    pe.reward_scale = e.reward_scale;
    pe.goals = e.goals;
    p.entries.push_back(pe);
  }
  // one width over both splits: a policy trained on one split runs on the other
  for (const auto* l : {&suite.train, &suite.test})
    for (const auto& e : *l) {
      const tasks::TaskSpec& ts = tasks::find_task(e.task).spec();
      p.obs_pad = std::max(p.obs_pad, ts.obs.dim());
      p.act_pad = std::max(p.act_pad, ts.act.dim());
    }
  p.one_hot = suite.mode == PackMode::kMultiTask ? static_cast<int>(suite.train.size()) : 0;
  return p;
}

std::string known_suites_text(bool held_out) {
  std::vector<std::string> ids;
  for (const auto& id : known_suites())
    if (load_suite(id).held_out() == held_out) ids.push_back(id);
  return join(ids);
}

}  // namespace bidex::taskpack
