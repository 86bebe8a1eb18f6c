// A task's spec with the agents of one multi-agent split, as JSON: what `bidex info --json`
// prints and what the Python module hands to Python (python/_bidex.cc), from one place.
#pragma once

#include <nlohmann/json.hpp>

#include "marl/split.h"
#include "tasks/spec.h"

namespace bidex::marl {

// id, version, names, age, difficulty, skill, episode length, base, widths, the named slices of
// the observation and the action (name, start, size, end, goal, doc), the split's agents (name,
// obs and act slices, obs_columns and act_columns), reward terms and the default YAML's path.
nlohmann::json task_spec_json(const tasks::TaskSpec& spec, const AgentSplit& split);

}  // namespace bidex::marl
