// TaskSpec: the static description of a task (identity, the paper's human age and difficulty,
// episode length, the named slices of its observation and action vectors, its agents and reward
// terms). One constant instance per task; `bidex info --task ID` prints it.
#pragma once

#include <string>
#include <vector>

#include "tasks/hand_body.h"

namespace bidex::tasks {

// A named, contiguous range of an observation or action vector.
struct Slice {
  std::string name;  // e.g. "right.dof_pos", "object.pose", "goal.rot_diff"
  int start = 0;
  int size = 0;
  std::string doc;    // content, units and scaling
  bool goal = false;  // describes the goal (meta-RL masks these)
  int end() const { return start + size; }
};

// A vector layout: slices in order, without gaps.
class Layout {
 public:
  // Appends a slice after the last one.
  Layout& add(std::string name, int size, std::string doc, bool goal = false);
  const std::vector<Slice>& slices() const { return slices_; }
  int dim() const { return slices_.empty() ? 0 : slices_.back().end(); }
  // nullptr when absent.
  const Slice* find(const std::string& name) const;
  // Like find, but throws bidex::Error naming the layout's slices.
  const Slice& at(const std::string& name) const;

 private:
  std::vector<Slice> slices_;
};

// An agent of the multi-agent setting: which slices it observes and which it acts on.
struct AgentSpec {
  std::string name;
  std::vector<std::string> obs;  // slice names of the observation
  std::vector<std::string> act;  // slice names of the action
};

enum class Difficulty { kEasy, kMedium, kHard };
const char* difficulty_name(Difficulty d);

// The age (months) at which infants acquire the skill, from the paper's task table.
struct HumanAge {
  int min_months = 0;
  int max_months = 0;      // == min_months for a single age
  std::string text;        // as the paper writes it: "48", "9-10", "adult"
  // The paper's source comments the row out (the catch tasks other than catch_underarm): the
  // value is still the paper's, but it is not in the printed table.
  bool from_commented_row = false;
};

struct RewardTermSpec {
  std::string name;
  std::string doc;
};

struct TaskSpec {
  std::string id;             // e.g. "catch_underarm"
  int version = 1;            // bumped whenever the task's dynamics, reward or layout change
  std::string paper_name;     // e.g. "Catch Underarm"
  std::string original_name;  // e.g. "ShadowHandCatchUnderarm"
  HumanAge age;
  Difficulty difficulty = Difficulty::kEasy;
  std::string skill;          // the human skill, paraphrasing the paper's table
  int episode_length = 0;     // control steps (60 Hz)
  bool free_base = false;     // hands on 6-DoF bases (52 actions) or fixed (40)
  // The two hands collide with each other, as in the original's tasks whose hands it created
  // with collision filter 0; where it passed -1 (the MJCF's contype 1, conaffinity 0 on every
  // hand geom), its hands passed through each other, and so do ours (sim/README.md, "Collision
  // pairs").
  bool hands_collide = true;
  Layout obs, act;
  std::vector<AgentSpec> agents;
  std::vector<RewardTermSpec> reward_terms;  // the reward is the sum of these terms
  // Empty for the paper's twenty tasks; for a variant, the id of the task it derives from: a
  // reduced task that learns in CI (never in a suite), or a suite's form of a task
  // (hand_over_free: hand_over with the free bases of the MT4/ML4 suites).
  std::string variant_of;
  // Goals whose position a slot's task parameters shift (TaskEnv::set_goal_shifts; meta-RL's
  // goal distributions); 0: the task takes no per-slot goal.
  int goal_shifts = 0;

  std::string versioned_id() const { return id + "-v" + std::to_string(version); }
  int term_index(const std::string& name) const;  // -1 when absent
};

// The per-hand part of every layout (paper, Appendix A): the hand blocks of the observation and
// the hand slices of the action, for fixed (187 obs / 20 act) or free (199 / 26) bases.
void add_hand_obs(Layout& obs, const std::string& side, bool free_base);
void add_hand_act(Layout& act, const std::string& side, bool free_base);
// Observation widths of one hand block: kHandObsFixed, kHandObsFree (tasks/hand_body.h).

// A spec with its names, age, difficulty, skill and episode length, and the two hand blocks of
// the observation and the action (fixed or free bases); the task adds its tail, terms, agents.
TaskSpec two_hand_spec(std::string id, std::string paper_name, std::string original_name,
                       HumanAge age, Difficulty difficulty, std::string skill, int episode_length,
                       bool free_base);

// One agent per hand: its own hand block plus every non-hand slice of the observation (the
// task tail), and its own action slices.
std::vector<AgentSpec> agents_per_hand(const Layout& obs, const Layout& act);

// The six parts of one hand that the original's finger agents act on (its handAgentIndex ids
// 0-5, in that order): the palm (the wrist's two joints, and the base's six forces and torques
// when the base is free), then the first, middle, ring and little fingers and the thumb. Each
// holds a range of the hand's `<side>.joints` slice (the 20 actuated joints in tree order).
struct HandPart {
  std::string name;       // palm, ff, mf, rf, lf, th
  int joint_begin = 0;    // [joint_begin, joint_end) of <side>.joints
  int joint_end = 0;
  bool base = false;      // also the base slices (free bases only)
};
const std::vector<HandPart>& hand_parts();

}  // namespace bidex::tasks
