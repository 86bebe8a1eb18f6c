// Agents of the multi-agent setting: which observation columns each agent sees and which action
// columns it sets, derived from a task's named layout (tasks/spec.h). Three splits:
//   hand    two agents, each with its hand's action slices (the original's default);
//   finger  six agents per hand on tasks::hand_parts(): palm (wrist, and the base when free),
//           ff, mf, rf, lf, th (the original's [[0], [1], ..., [5]]);
//   a list  any grouping, written in YAML (below).
// By default an agent sees the blocks of the hands it acts on plus every non-hand slice (object,
// goal: the task tail), as the original's agents do; the critic of a centralised algorithm sees
// the whole observation. Splits are checked against the layout: every action column belongs to
// exactly one agent, and a bad grouping is a ConfigError naming the columns.
//
// The YAML form (the `agents` key of a multi-agent section, or the file of --agents FILE):
//   - a list of agents, each a map
//       {name: right_palm, act: [right.palm], obs: [right, tail]}
//     `act` names action slices of the layout (right.joints, right.base_translation, ...) or hand
//     parts (right.palm, right.ff, ..., left.th; right.base: both base slices); `obs` (optional)
//     names observation slices, groups of them (`right`, `object`, `goal`: every slice named
//     right.*, ...) or `tail` (every slice outside the hand blocks);
//   - or the original's handAgentIndex, a list of groups of part ids applied to both hands:
//       [[0], [1, 2, 3, 4, 5]]   (four agents: right_0, right_1, left_0, left_1)
// Torch-free: the Python module (python/) builds the same splits; marl/agents.h adds what
// LibTorch needs (checkpoints, the views on a device).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/yaml.h"
#include "tasks/spec.h"

namespace bidex::marl {

struct Agent {
  std::string name;               // "right", "left_ff", or as written
  std::vector<int64_t> obs_cols;  // observation columns it sees, ascending
  std::vector<int64_t> act_cols;  // action columns it sets, ascending
  std::vector<std::string> obs_names, act_names;  // the slices / parts, as resolved
};

struct AgentSplit {
  std::string kind;  // hand, finger or custom
  std::vector<Agent> agents;
  int64_t obs_dim = 0, act_dim = 0;  // the task's full widths
};

// The split `agents` names for `spec`: the scalar `hand` or `finger`, or a list (above). `where`
// names the file and key in errors (e.g. "run/config.yaml" key "mappo.agents").
AgentSplit split_agents(const tasks::TaskSpec& spec, const YamlView& agents);
AgentSplit hand_split(const tasks::TaskSpec& spec);
AgentSplit finger_split(const tasks::TaskSpec& spec);

// The --agents argument of bidex train and info: hand, finger, or a YAML file holding a list of
// agents (or a map with the key `agents`); a bad file's errors name it. `yaml` (if given) gets
// the value for the run's config, in YAML's flow style.
AgentSplit agents_from_arg(const tasks::TaskSpec& spec, const std::string& arg,
                           std::string* yaml = nullptr);

// One line per agent ("right_ff  sees 211 (right, tail), acts on 3: [2, 5) (right.ff)"), for
// bidex info.
std::string describe(const AgentSplit& split);
// Ascending columns as ranges: "[0, 2), [20, 26)".
std::string ranges_text(const std::vector<int64_t>& cols);

}  // namespace bidex::marl
