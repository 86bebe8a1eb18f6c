#include "tasks/spec.h"

#include "core/error.h"

namespace bidex::tasks {

Layout& Layout::add(std::string name, int size, std::string doc, bool goal) {
  Slice s;
  s.name = std::move(name);
  s.start = dim();
  s.size = size;
  s.doc = std::move(doc);
  s.goal = goal;
  slices_.push_back(std::move(s));
  return *this;
}

const Slice* Layout::find(const std::string& name) const {
  for (auto& s : slices_)
    if (s.name == name) return &s;
  return nullptr;
}

const Slice& Layout::at(const std::string& name) const {
  if (auto* s = find(name)) return *s;
  std::string names;
  for (auto& s : slices_) names += (names.empty() ? "" : ", ") + s.name;
  throw Error("no slice '" + name + "' (slices: " + names + ")");
}

const char* difficulty_name(Difficulty d) {
  switch (d) {
    case Difficulty::kEasy: return "easy";
    case Difficulty::kMedium: return "medium";
    case Difficulty::kHard: return "hard";
  }
  return "?";
}

int TaskSpec::term_index(const std::string& name) const {
  for (size_t i = 0; i < reward_terms.size(); ++i)
    if (reward_terms[i].name == name) return static_cast<int>(i);
  return -1;
}

void add_hand_obs(Layout& obs, const std::string& side, bool free_base) {
  const std::string p = side + ".";
  obs.add(p + "dof_pos", 24, "joint angles, tree order, scaled to [-1, 1] by the joint range");
  obs.add(p + "dof_vel", 24, "joint velocities (rad/s) x 0.2");
  obs.add(p + "dof_force", 24,
          "joint torques (N m) x 10: the motor torque of driven joints, the coupling (constraint) "
          "torque of the four coupled distal joints");
  obs.add(p + "fingertip_state", 65,
          "5 fingertips (ff, mf, rf, lf, th) x [position 3, quaternion (x, y, z, w) 4, linear "
          "velocity 3, angular velocity 3], world frame, at each distal body's origin");
  obs.add(p + "fingertip_force", 30, "5 fingertips x [force 3, torque 3] (N, N m) x 10");
  if (free_base) {
    obs.add(p + "base_pos", 3, "position of the hand's base (forearm origin), world frame");
    obs.add(p + "base_rot", 3, "orientation of the base as roll, pitch, yaw, each in [0, 2 pi)");
  }
  obs.add(p + "actions", free_base ? 26 : 20, "this hand's actions of the last step, clipped");
}

void add_hand_act(Layout& act, const std::string& side, bool free_base) {
  const std::string p = side + ".";
  act.add(p + "joints", 20,
          "targets of the 20 actuated joints, tree order: -1..1 spans each joint's range");
  if (free_base) {
    act.add(p + "base_translation", 3, "world-frame force on the base, -1..1 of the task's maximum");
    act.add(p + "base_rotation", 3, "world-frame torque on the base, -1..1 of the task's maximum");
  }
}

std::vector<AgentSpec> agents_per_hand(const Layout& obs, const Layout& act) {
  std::vector<AgentSpec> agents;
  for (const char* side : {"right", "left"}) {
    AgentSpec a;
    a.name = side;
    const std::string p = std::string(side) + ".";
    for (auto& s : obs.slices()) {
      bool hand = s.name.rfind("right.", 0) == 0 || s.name.rfind("left.", 0) == 0;
      if (!hand || s.name.rfind(p, 0) == 0) a.obs.push_back(s.name);
    }
    for (auto& s : act.slices())
      if (s.name.rfind(p, 0) == 0) a.act.push_back(s.name);
    agents.push_back(std::move(a));
  }
  return agents;
}

const std::vector<HandPart>& hand_parts() {
  // tree order of the actuated joints: WRJ1 WRJ0 | FFJ3-1 | MFJ3-1 | RFJ3-1 | LFJ4-1 | THJ4-0
  static const std::vector<HandPart> parts = {{"palm", 0, 2, true}, {"ff", 2, 5, false},
                                              {"mf", 5, 8, false},  {"rf", 8, 11, false},
                                              {"lf", 11, 15, false}, {"th", 15, 20, false}};
  return parts;
}

TaskSpec two_hand_spec(std::string id, std::string paper_name, std::string original_name,
                       HumanAge age, Difficulty difficulty, std::string skill, int episode_length,
                       bool free_base) {
  TaskSpec s;
  s.id = std::move(id);
  s.paper_name = std::move(paper_name);
  s.original_name = std::move(original_name);
  s.age = std::move(age);
  s.difficulty = difficulty;
  s.skill = std::move(skill);
  s.episode_length = episode_length;
  s.free_base = free_base;
  add_hand_obs(s.obs, "right", free_base);
  add_hand_obs(s.obs, "left", free_base);
  add_hand_act(s.act, "right", free_base);
  add_hand_act(s.act, "left", free_base);
  return s;
}

}  // namespace bidex::tasks
