// marl/agents: the hand, finger and YAML splits against each task's named layout and the hand's
// actuated joints; bad groupings are ConfigErrors naming the columns; the views on tensors.
#include "tests/rl/rl_fixture.h"

#include <set>

#include "marl/agents.h"
#include "sim/hand_spec.h"
#include "tasks/registry.h"
#include "tests/fixture.h"

using namespace bidex;

namespace {

const tasks::TaskSpec& spec_of(const std::string& id) { return tasks::find_task(id).spec(); }

std::vector<int64_t> cols_of(const tasks::Layout& l, const std::string& prefix) {
  std::vector<int64_t> v;
  for (auto& s : l.slices())
    if (s.name.rfind(prefix, 0) == 0)
      for (int c = s.start; c < s.end(); ++c) v.push_back(c);
  return v;
}

std::vector<int64_t> range(int64_t a, int64_t b) {
  std::vector<int64_t> v;
  for (int64_t c = a; c < b; ++c) v.push_back(c);
  return v;
}

ConfigError split_error(const std::string& task, const std::string& yaml) {
  test::TaskTempDir dir;
  const std::string f = dir.write("agents.yaml", yaml);
  return test::config_error([&] { marl::agents_from_arg(spec_of(task), f); });
}

}  // namespace

TEST_CASE("per-hand agents see their own hand block and the task tail, as the original's",
          "[marl][agents]") {
  for (auto* reg : {&tasks::task_registry(), &tasks::variant_registry()})
    for (auto& e : *reg) {
      const tasks::TaskSpec& sp = e.spec();
      INFO(sp.id);
      const marl::AgentSplit s = marl::hand_split(sp);
      REQUIRE(s.agents.size() == 2);
      const int64_t hand = sp.free_base ? 199 : 187;  // one hand block (upstream section 3.4)
      for (int i = 0; i < 2; ++i) {
        const std::string side = i == 0 ? "right" : "left";
        const auto& a = s.agents[i];
        CHECK(a.name == side);
        CHECK(a.act_cols == cols_of(sp.act, side + "."));
        CHECK(a.act_cols.size() == (sp.free_base ? 26u : 20u));
        // obs_right = [obs[0:H], obs[2H:]], obs_left = [obs[H:2H], obs[2H:]]
        std::vector<int64_t> want = range(i * hand, (i + 1) * hand);
        for (int64_t c : range(2 * hand, sp.obs.dim())) want.push_back(c);
        CHECK(a.obs_cols == want);
        CHECK(static_cast<int64_t>(a.obs_cols.size()) == sp.obs.dim() - hand);
      }
    }
  // the original's widths: 211 for hand_over, 223 for catch_underarm
  CHECK(marl::hand_split(spec_of("hand_over")).agents[0].obs_cols.size() == 211);
  CHECK(marl::hand_split(spec_of("catch_underarm")).agents[1].obs_cols.size() == 223);
}

TEST_CASE("finger agents act on the original's groups, which match the hand's actuated joints",
          "[marl][agents]") {
  // the joints of each part, by name, from the hand's own spec (tree order of the 20 actions)
  const auto joints = test::shadow().actuated_joints();
  REQUIRE(joints.size() == 20);
  const std::vector<std::string> prefix = {"WR", "FF", "MF", "RF", "LF", "TH"};
  const auto& parts = tasks::hand_parts();
  REQUIRE(parts.size() == 6);
  for (size_t p = 0; p < parts.size(); ++p)
    for (int j = 0; j < 20; ++j) {
      const bool in = j >= parts[p].joint_begin && j < parts[p].joint_end;
      INFO(parts[p].name << " joint " << j << " " << joints[j]->name);
      CHECK(in == (joints[j]->name.rfind(prefix[p], 0) == 0));
    }

  for (const char* id : {"hand_over", "catch_underarm"}) {
    const tasks::TaskSpec& sp = spec_of(id);
    INFO(id);
    const marl::AgentSplit s = marl::finger_split(sp);
    REQUIRE(s.agents.size() == 12);
    // the original's action widths per group: palm 8 (free base) or 2, ff 3, mf 3, rf 3, lf 4,
    // th 5
    const std::vector<size_t> widths = {sp.free_base ? 8u : 2u, 3, 3, 3, 4, 5};
    std::set<int64_t> all;
    for (int i = 0; i < 12; ++i) {
      const auto& a = s.agents[i];
      const std::string side = i < 6 ? "right" : "left";
      CHECK(a.name == side + "_" + parts[i % 6].name);
      CHECK(a.act_cols.size() == widths[i % 6]);
      // every agent of a hand sees that hand's whole block and the tail
      CHECK(a.obs_cols == marl::hand_split(sp).agents[i / 6].obs_cols);
      const auto joints_slice = sp.act.at(side + ".joints");
      for (int64_t c : a.act_cols) {
        all.insert(c);
        const bool joint = c >= joints_slice.start && c < joints_slice.end();
        if (joint) {
          CHECK(c - joints_slice.start >= parts[i % 6].joint_begin);
          CHECK(c - joints_slice.start < parts[i % 6].joint_end);
        } else {
          CHECK(i % 6 == 0);  // only the palm takes the base's forces and torques
        }
      }
    }
    CHECK(static_cast<int64_t>(all.size()) == sp.act.dim());
  }
}

TEST_CASE("YAML splits: named agents with their own views, and the original's groups",
          "[marl][agents]") {
  const tasks::TaskSpec& sp = spec_of("catch_underarm");
  test::TaskTempDir dir;
  SECTION("the original's handAgentIndex, applied to both hands") {
    const std::string f = dir.write("groups.yaml", "[[0], [1, 2, 3, 4, 5]]\n");
    std::string yaml;
    const marl::AgentSplit s = marl::agents_from_arg(sp, f, &yaml);
    REQUIRE(s.agents.size() == 4);
    CHECK(s.kind == "custom");
    CHECK(s.agents[0].name == "right_0");
    std::vector<int64_t> palm = range(0, 2);
    for (int64_t c : range(20, 26)) palm.push_back(c);
    CHECK(s.agents[0].act_cols == palm);
    CHECK(s.agents[1].act_cols == range(2, 20));
    CHECK(s.agents[3].act_cols == range(28, 46));
    // the flow text it puts in a run's config reads back to the same split
    auto back = marl::split_agents(sp, YamlView::load_string(yaml, "config"));
    CHECK(back.agents[2].act_cols == s.agents[2].act_cols);
  }
  SECTION("named agents, one with a chosen view") {
    const std::string f = dir.write("named.yaml",
                                    "agents:\n"
                                    "  - {name: r, act: [right.joints, right.base], "
                                    "obs: [right, object.pose, goal]}\n"
                                    "  - {name: l, act: [left.joints, left.base]}\n");
    const marl::AgentSplit s = marl::agents_from_arg(sp, f);
    REQUIRE(s.agents.size() == 2);
    std::vector<int64_t> want = cols_of(sp.obs, "right.");
    for (int64_t c : cols_of(sp.obs, "object.pose")) want.push_back(c);
    for (int64_t c : cols_of(sp.obs, "goal.")) want.push_back(c);
    std::sort(want.begin(), want.end());
    CHECK(s.agents[0].obs_cols == want);
    CHECK(s.agents[1].obs_cols == marl::hand_split(sp).agents[1].obs_cols);
  }
}

TEST_CASE("a bad grouping is refused with a ConfigError naming the file and the columns",
          "[marl][agents]") {
  SECTION("a column in two agents") {
    auto e = split_error("catch_underarm", "- {name: a, act: [right.joints, left.ff]}\n"
                                           "- {name: b, act: [left.joints, right.base, "
                                           "left.base]}\n");
    CHECK(std::string(e.what()).find("agents.yaml") != std::string::npos);
    CHECK(e.actual().find("columns [28, 31) (left.joints) in agents 'a' and 'b'") !=
          std::string::npos);
  }
  SECTION("columns in no agent") {
    auto e = split_error("catch_underarm", "- {name: a, act: [right.joints]}\n"
                                           "- {name: b, act: [left.joints]}\n");
    CHECK(e.expected() == "every action column in an agent");
    CHECK(e.actual() == "columns [20, 26), [46, 52) (right.base_translation, "
                        "right.base_rotation, left.base_translation, left.base_rotation) in none");
  }
  SECTION("an unknown action part, listing the known ones") {
    auto e = split_error("hand_over", "- {name: a, act: [right.base]}\n");
    CHECK(e.key() == "[0].act");
    CHECK(e.actual() == "'right.base'");  // hand_over's bases are fixed
    CHECK(e.expected().find("right.ff") != std::string::npos);
  }
  SECTION("an unknown observation group") {
    auto e = split_error("hand_over", "- {name: a, act: [right.joints], obs: [right, cup]}\n"
                                      "- {name: b, act: [left.joints]}\n");
    CHECK(e.key() == "[0].obs");
    CHECK(e.actual() == "'cup'");
  }
  SECTION("a part id out of range, a duplicate name, an unknown key") {
    CHECK(split_error("hand_over", "[[0, 1, 2], [3, 4, 6]]\n").actual() == "6");
    CHECK(split_error("hand_over", "- {name: a, act: [right.joints]}\n"
                                   "- {name: a, act: [left.joints]}\n")
              .key() == "[1].name");
    CHECK(split_error("hand_over", "- {name: a, act: [right.joints], acts: [x]}\n")
              .actual()
              .find("acts") != std::string::npos);
    CHECK(split_error("hand_over", "three\n").actual() == "'three'");
  }
}

TEST_CASE("agent views select each agent's columns and assemble the action rows",
          "[marl][agents]") {
  const tasks::TaskSpec& sp = spec_of("catch_underarm");
  for (const auto& split : {marl::hand_split(sp), marl::finger_split(sp)}) {
    marl::AgentViews v(split, torch::kCPU);
    auto obs = torch::randn({5, sp.obs.dim()});
    auto act = torch::randn({3, 5, sp.act.dim()});
    std::vector<torch::Tensor> parts;
    for (int64_t i = 0; i < v.count(); ++i) {
      const auto& a = split.agents[i];
      auto o = v.obs(obs, i);
      REQUIRE(o.size(1) == static_cast<int64_t>(a.obs_cols.size()));
      CHECK(torch::equal(o.select(1, 0), obs.select(1, a.obs_cols.front())));
      CHECK(torch::equal(o.select(1, o.size(1) - 1), obs.select(1, a.obs_cols.back())));
      parts.push_back(v.actions(act, i));
      CHECK(parts.back().size(2) == v.act_dim(i));
    }
    CHECK(torch::equal(v.assemble(parts), act));
  }
}
