#include "marl/spec_json.h"

#include "tasks/registry.h"

namespace bidex::marl {

using nlohmann::json;

namespace {

json layout_json(const tasks::Layout& l) {
  json out = json::array();
  for (auto& s : l.slices())
    out.push_back({{"name", s.name}, {"start", s.start}, {"size", s.size}, {"end", s.end()},
                   {"goal", s.goal}, {"doc", s.doc}});
  return out;
}

}  // namespace

json task_spec_json(const tasks::TaskSpec& sp, const marl::AgentSplit& split) {
  json agents = json::array();
  for (auto& a : split.agents)
    agents.push_back({{"name", a.name}, {"obs", a.obs_names}, {"act", a.act_names},
                      {"obs_columns", a.obs_cols}, {"act_columns", a.act_cols}});
  json terms = json::array();
  for (auto& t : sp.reward_terms) terms.push_back({{"name", t.name}, {"doc", t.doc}});
  return {{"id", sp.id},
          {"version", sp.version},
          {"versioned_id", sp.versioned_id()},
          {"paper_name", sp.paper_name},
          {"original_name", sp.original_name},
          {"age", {{"min_months", sp.age.min_months},
                   {"max_months", sp.age.max_months},
                   {"text", sp.age.text},
                   {"from_commented_row", sp.age.from_commented_row}}},
          {"difficulty", tasks::difficulty_name(sp.difficulty)},
          {"skill", sp.skill},
          {"episode_length", sp.episode_length},
          {"base", sp.free_base ? "free" : "fixed"},
          {"obs_dim", sp.obs.dim()},
          {"act_dim", sp.act.dim()},
          {"obs", layout_json(sp.obs)},
          {"act", layout_json(sp.act)},
          {"agents", agents},
          {"agent_split", split.kind},
          {"reward_terms", terms},
          {"default_config", tasks::default_task_config(sp.id)}};
}

}  // namespace bidex::marl
