#include "marl/split.h"

#include <algorithm>
#include <map>
#include <set>

#include "core/error.h"

namespace bidex::marl {

namespace {

const char* const kSides[] = {"right", "left"};

bool has_prefix(const std::string& s, const std::string& p) { return s.rfind(p, 0) == 0; }
bool is_hand_slice(const std::string& s) {
  return has_prefix(s, "right.") || has_prefix(s, "left.");
}

std::vector<int64_t> range(int begin, int end) {
  std::vector<int64_t> v;
  for (int c = begin; c < end; ++c) v.push_back(c);
  return v;
}

// The names an agent's `act` may use, each with its columns: the action layout's slices, and per
// hand `<side>.base` and the hand parts of tasks::hand_parts().
std::map<std::string, std::vector<int64_t>> action_parts(const tasks::TaskSpec& spec) {
  std::map<std::string, std::vector<int64_t>> parts;
  for (auto& s : spec.act.slices()) parts[s.name] = range(s.start, s.end());
  for (const char* side : kSides) {
    const std::string p = std::string(side) + ".";
    const tasks::Slice* joints = spec.act.find(p + "joints");
    if (!joints) continue;
    std::vector<int64_t> base;
    for (const char* b : {"base_translation", "base_rotation"})
      if (const tasks::Slice* s = spec.act.find(p + b))
        for (int64_t c : range(s->start, s->end())) base.push_back(c);
    if (!base.empty()) parts[p + "base"] = base;
    for (auto& hp : tasks::hand_parts()) {
      auto cols = range(joints->start + hp.joint_begin, joints->start + hp.joint_end);
      if (hp.base) cols.insert(cols.end(), base.begin(), base.end());
      std::sort(cols.begin(), cols.end());
      parts[p + hp.name] = cols;
    }
  }
  return parts;
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

}  // namespace

std::string ranges_text(const std::vector<int64_t>& cols) {
  std::string out;
  for (size_t i = 0; i < cols.size();) {
    size_t j = i + 1;
    while (j < cols.size() && cols[j] == cols[j - 1] + 1) ++j;
    out += (out.empty() ? "" : ", ") + std::string("[") + std::to_string(cols[i]) + ", " +
           std::to_string(cols[j - 1] + 1) + ")";
    i = j;
  }
  return out;
}

namespace {

// "[20, 26) (right.base_translation, right.base_rotation)": `cols` (ascending) as ranges, with
// the layout slices they fall in
std::string cols_text(const std::vector<int64_t>& cols, const tasks::Layout& layout) {
  const std::string out = ranges_text(cols);
  std::vector<std::string> names;
  for (auto& s : layout.slices())
    for (int64_t c : cols)
      if (c >= s.start && c < s.end()) {
        names.push_back(s.name);
        break;
      }
  return out + " (" + join(names) + ")";
}

// The observation columns of the names in `obs`: slice names, `right` / `left`, `tail`.
std::vector<int64_t> obs_columns(const tasks::TaskSpec& spec, const std::vector<std::string>& obs,
                                 const YamlView* where) {
  std::set<int64_t> cols;
  for (auto& name : obs) {
    bool found = false;
    for (auto& s : spec.obs.slices()) {
      const bool take = s.name == name || has_prefix(s.name, name + ".") ||
                        (name == "tail" && !is_hand_slice(s.name));
      if (!take) continue;
      found = true;
      for (int c = s.start; c < s.end(); ++c) cols.insert(c);
    }
    if (!found) {
      std::vector<std::string> known = {"tail"};
      for (auto& s : spec.obs.slices()) {
        const std::string group = s.name.substr(0, s.name.find('.'));
        if (std::find(known.begin(), known.end(), group) == known.end()) known.push_back(group);
      }
      for (auto& s : spec.obs.slices()) known.push_back(s.name);
      const std::string expected = "observation slices of " + spec.id + " (" + join(known) + ")";
      if (where) where->fail(expected, "'" + name + "'");
      throw Error("agents: no observation slice '" + name + "' (" + expected + ")");
    }
  }
  return {cols.begin(), cols.end()};
}

// The default view of an agent: the blocks of the hands it acts on, and the task tail.
std::vector<std::string> default_obs(const tasks::TaskSpec& spec,
                                     const std::vector<int64_t>& act_cols) {
  std::vector<std::string> obs;
  for (const char* side : kSides)
    for (auto& s : spec.act.slices()) {
      if (!has_prefix(s.name, std::string(side) + ".")) continue;
      if (std::any_of(act_cols.begin(), act_cols.end(),
                      [&](int64_t c) { return c >= s.start && c < s.end(); })) {
        obs.push_back(side);
        break;
      }
    }
  obs.push_back("tail");
  return obs;
}

Agent make_agent(const tasks::TaskSpec& spec,
                 const std::map<std::string, std::vector<int64_t>>& parts, std::string name,
                 std::vector<std::string> act, std::vector<std::string> obs,
                 const YamlView* act_where, const YamlView* obs_where) {
  Agent a;
  a.name = std::move(name);
  std::set<int64_t> cols;
  for (auto& p : act) {
    auto it = parts.find(p);
    if (it == parts.end()) {
      std::vector<std::string> known;
      for (auto& [k, v] : parts) known.push_back(k);
      const std::string expected = "action slices or hand parts of " + spec.id + " (" +
                                   join(known) + ")";
      if (act_where) act_where->fail(expected, "'" + p + "'");
      throw Error("agents: no action part '" + p + "' (" + expected + ")");
    }
    cols.insert(it->second.begin(), it->second.end());
  }
  a.act_cols.assign(cols.begin(), cols.end());
  a.act_names = std::move(act);
  if (obs.empty()) obs = default_obs(spec, a.act_cols);
  a.obs_cols = obs_columns(spec, obs, obs_where);
  a.obs_names = std::move(obs);
  return a;
}

// A split of `kind` with no agents yet, of the task's widths.
AgentSplit empty_split(const tasks::TaskSpec& spec, const char* kind) {
  AgentSplit split;
  split.kind = kind;
  split.obs_dim = spec.obs.dim();
  split.act_dim = spec.act.dim();
  return split;
}

// Every action column in exactly one agent; `where` names the YAML in errors.
void check_cover(const tasks::TaskSpec& spec, const AgentSplit& split, const YamlView* where) {
  std::vector<int> owner(spec.act.dim(), -1);
  auto fail = [&](const std::string& expected, const std::string& actual) {
    if (where) where->fail(expected, actual);
    throw Error("agents of " + spec.id + ": expected " + expected + ", found " + actual);
  };
  for (size_t i = 0; i < split.agents.size(); ++i) {
    std::vector<int64_t> clash;
    int other = -1;
    for (int64_t c : split.agents[i].act_cols) {
      if (owner[c] >= 0) {
        clash.push_back(c);
        other = owner[c];
      } else {
        owner[c] = static_cast<int>(i);
      }
    }
    if (!clash.empty())
      fail("each action column in one agent",
           "columns " + cols_text(clash, spec.act) + " in agents '" +
               split.agents[other].name + "' and '" + split.agents[i].name + "'");
  }
  std::vector<int64_t> missing;
  for (int c = 0; c < spec.act.dim(); ++c)
    if (owner[c] < 0) missing.push_back(c);
  if (!missing.empty())
    fail("every action column in an agent", "columns " + cols_text(missing, spec.act) +
                                                " in none");
}

std::vector<std::string> strings(const YamlView& list) {
  list.expect_seq();
  std::vector<std::string> out;
  for (auto& item : list.items()) out.push_back(item.as<std::string>());
  if (out.empty()) list.fail("a non-empty list of names", "[]");
  return out;
}

}  // namespace

AgentSplit hand_split(const tasks::TaskSpec& spec) {
  AgentSplit split = empty_split(spec, "hand");
  const auto parts = action_parts(spec);
  for (auto& a : spec.agents)
    split.agents.push_back(make_agent(spec, parts, a.name, a.act, {}, nullptr, nullptr));
  check_cover(spec, split, nullptr);
  return split;
}

AgentSplit finger_split(const tasks::TaskSpec& spec) {
  AgentSplit split = empty_split(spec, "finger");
  const auto parts = action_parts(spec);
  for (const char* side : kSides)
    for (auto& hp : tasks::hand_parts())
      split.agents.push_back(make_agent(spec, parts, std::string(side) + "_" + hp.name,
                                        {std::string(side) + "." + hp.name}, {}, nullptr,
                                        nullptr));
  check_cover(spec, split, nullptr);
  return split;
}

AgentSplit split_agents(const tasks::TaskSpec& spec, const YamlView& agents) {
  if (agents.node().IsScalar()) {
    const std::string s = agents.as<std::string>();
    if (s == "hand") return hand_split(spec);
    if (s == "finger") return finger_split(spec);
    agents.fail("hand, finger, or a list of agents", "'" + s + "'");
  }
  if (!agents.is_seq() || agents.node().size() == 0)
    agents.fail("hand, finger, or a non-empty list of agents", agents.repr());
  AgentSplit split = empty_split(spec, "custom");
  const auto parts = action_parts(spec);
  const auto items = agents.items();
  if (items.front().is_seq()) {
    // the original's handAgentIndex: groups of part ids, applied to each hand
    const auto& hp = tasks::hand_parts();
    for (const char* side : kSides)
      for (size_t g = 0; g < items.size(); ++g) {
        items[g].expect_seq();
        std::vector<std::string> act;
        for (auto& id : items[g].items()) {
          const int k = id.as<int>();
          if (k < 0 || k >= static_cast<int>(hp.size()))
            id.fail("a hand part id 0-5 (0 palm, 1 ff, 2 mf, 3 rf, 4 lf, 5 th)",
                    std::to_string(k));
          act.push_back(std::string(side) + "." + hp[k].name);
        }
        if (act.empty()) items[g].fail("a non-empty group of hand part ids", "[]");
        split.agents.push_back(make_agent(spec, parts, std::string(side) + "_" +
                                          std::to_string(g), act, {}, &items[g], nullptr));
      }
  } else {
    std::set<std::string> names;
    for (auto& item : items) {
      item.allow_keys({"name", "act", "obs"});
      const std::string name = item.req<std::string>("name");
      if (name.empty() || !names.insert(name).second)
        item.child("name").fail("a unique, non-empty agent name", "'" + name + "'");
      const YamlView act = item.child("act");
      std::vector<std::string> obs;
      std::optional<YamlView> obs_view = item.maybe("obs");
      if (obs_view) obs = strings(*obs_view);
      split.agents.push_back(make_agent(spec, parts, name, strings(act), obs, &act,
                                        obs_view ? &*obs_view : nullptr));
    }
  }
  check_cover(spec, split, &agents);
  return split;
}

AgentSplit agents_from_arg(const tasks::TaskSpec& spec, const std::string& arg,
                           std::string* yaml) {
  if (arg == "hand" || arg == "finger") {
    if (yaml) *yaml = arg;
    return arg == "hand" ? hand_split(spec) : finger_split(spec);
  }
  YamlView file = YamlView::load_file(arg);  // missing: an IoError naming it
  const YamlView list = file.is_map() ? file.child("agents") : file;
  if (file.is_map()) file.allow_keys({"agents"});
  AgentSplit split = split_agents(spec, list);
  if (yaml) {
    YAML::Emitter em;
    em.SetSeqFormat(YAML::Flow);
    em.SetMapFormat(YAML::Flow);
    em << list.node();
    *yaml = em.c_str();
  }
  return split;
}

std::string describe(const AgentSplit& split) {
  std::string out;
  size_t w = 0;
  for (auto& a : split.agents) w = std::max(w, a.name.size());
  for (auto& a : split.agents) {
    std::string line = "  " + a.name + std::string(w - a.name.size() + 2, ' ');
    line += "sees " + std::to_string(a.obs_cols.size()) + " (" + join(a.obs_names) +
            "), acts on " + std::to_string(a.act_cols.size()) + ": " + ranges_text(a.act_cols) +
            " (" + join(a.act_names) + ")\n";
    out += line;
  }
  return out;
}

}  // namespace bidex::marl
