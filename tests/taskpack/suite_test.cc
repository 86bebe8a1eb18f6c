// taskpack suites: every configs/suites file loads and is the canonical table (tasks, labels,
// splits, modes, reward scales, widths); MT1's goal variants put the goal where stated; bad
// suite files are ConfigErrors naming the file and the key.
#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <unistd.h>

#include <catch2/catch.hpp>

#include "sim/hand_spec.h"
#include "taskpack/pack.h"
#include "taskpack/suite.h"
#include "tasks/catch_family.h"
#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;
using taskpack::PackMode;
using taskpack::Suite;

namespace {

using Names = std::vector<std::string>;

// The paper's twenty tasks, in the canonical table's order (written out here).
const Names kTwenty = {"hand_over",          "catch_underarm",    "catch_over2underarm",
                       "catch_abreast",      "two_catch_underarm", "lift_underarm",
                       "door_open_outward",  "door_close_inward", "door_open_inward",
                       "door_close_outward", "bottle_cap",        "push_block",
                       "swing_cup",          "scissors",          "re_orientation",
                       "pen",                "switch",            "block_stack",
                       "pour_water",         "grasp_and_place"};
// The paper's list of tasks whose rewards MT20/ML20 scale by 0.1.
const Names kScaled = {"grasp_and_place",    "door_open_outward", "door_open_inward",
                       "bottle_cap",         "block_stack",       "door_close_inward",
                       "door_close_outward", "lift_underarm",     "re_orientation",
                       "scissors",           "swing_cup"};
const Names kMl20Test = {"door_close_outward", "hand_over", "lift_underarm", "scissors",
                         "two_catch_underarm"};

bool in(const Names& v, const std::string& x) { return std::find(v.begin(), v.end(), x) != v.end(); }

Names tasks_of(const std::vector<taskpack::SuiteEntry>& v) {
  Names out;
  for (auto& e : v) out.push_back(e.task);
  return out;
}
Names labels_of(const std::vector<taskpack::SuiteEntry>& v) {
  Names out;
  for (auto& e : v) out.push_back(e.label);
  return out;
}

std::string suites_dir() { return sim::data_dir() + "/configs/suites"; }

}  // namespace

TEST_CASE("every suite file loads and matches the canonical table", "[taskpack][suite]") {
  CHECK(taskpack::known_suites() ==
        Names{"MT1", "ML1", "MT4", "ML4", "MT20", "ML20", "ML1-goals", "ML1-raise-goals"});
  // meta-RL's suites hold test tasks out; the multi-task suites test on their train tasks
  CHECK(taskpack::known_suites_text(true) == "ML1, ML4, ML20, ML1-goals, ML1-raise-goals");
  CHECK(taskpack::known_suites_text(false) == "MT1, MT4, MT20");
  std::map<std::string, Suite> s;
  for (const auto& id : taskpack::known_suites()) {
    INFO("suite " << id);
    s[id] = taskpack::load_suite(id);
    CHECK(s[id].id == id);
    CHECK(s[id].file == suites_dir() + "/" + id + ".yaml");
    CHECK_FALSE(s[id].description.empty());
    CHECK_FALSE(s[id].source.empty());
    CHECK(s[id].mode == (id.rfind("MT", 0) == 0 ? PackMode::kMultiTask : PackMode::kMeta));
    if (s[id].mode == PackMode::kMultiTask) {
      CHECK(tasks_of(s[id].test) == tasks_of(s[id].train));
      CHECK(labels_of(s[id].test) == labels_of(s[id].train));
    }
    // only MT20/ML20 scale rewards, and exactly the paper's eleven by 0.1
    for (auto* list : {&s[id].train, &s[id].test})
      for (auto& e : *list) {
        INFO("entry " << e.label);
        const bool scaled = (id == "MT20" || id == "ML20") && in(kScaled, e.task);
        CHECK(e.reward_scale == (scaled ? 0.1 : 1.0));
        CHECK(tasks::find_task(e.task).spec().id == e.task);
      }
  }
  // by path as well as by id
  CHECK(taskpack::load_suite(suites_dir() + "/MT4.yaml").id == "MT4");

  const Names variants = {"original", "left", "right", "back"};
  CHECK(tasks_of(s["MT1"].train) == Names(4, "catch_underarm"));
  CHECK(labels_of(s["MT1"].train) == variants);
  CHECK(labels_of(s["ML1"].train) == Names{"original", "left", "right"});
  CHECK(labels_of(s["ML1"].test) == Names{"back"});
  CHECK(tasks_of(s["ML1"].test) == Names{"catch_underarm"});
  for (size_t i = 0; i < 4; ++i) {
    CHECK(s["MT1"].train[i].config == suites_dir() + "/goals/" + variants[i] + ".yaml");
    CHECK(::access(s["MT1"].train[i].config.c_str(), R_OK) == 0);
  }
  CHECK(s["ML1"].test[0].config == s["MT1"].train[3].config);

  CHECK(tasks_of(s["MT4"].train) ==
        Names{"catch_underarm", "hand_over_free", "catch_abreast", "two_catch_underarm"});
  CHECK(labels_of(s["MT4"].train) ==
        Names{"catch_underarm", "hand_over", "catch_abreast", "two_catch_underarm"});
  CHECK(tasks_of(s["ML4"].train) == Names{"catch_underarm", "hand_over_free", "catch_abreast"});
  CHECK(labels_of(s["ML4"].train)[1] == "hand_over");
  CHECK(tasks_of(s["ML4"].test) == Names{"two_catch_underarm"});
  // the MT4/ML4 hand over has free bases (the paper), a variant of the fixed-base task
  const auto& hof = tasks::find_task("hand_over_free").spec();
  CHECK(hof.free_base);
  CHECK(hof.variant_of == "hand_over");
  CHECK(hof.obs.dim() == 422);
  CHECK(hof.act.dim() == 52);

  CHECK(tasks_of(s["MT20"].train) == kTwenty);  // hand_over: the fixed-base paper task
  Names ml20_train;
  for (auto& t : kTwenty)
    if (!in(kMl20Test, t)) ml20_train.push_back(t);
  CHECK(tasks_of(s["ML20"].train) == ml20_train);
  Names ml20_test = tasks_of(s["ML20"].test);
  std::sort(ml20_test.begin(), ml20_test.end());
  CHECK(ml20_test == kMl20Test);
  int scaled = 0;
  for (auto& e : s["MT20"].train) scaled += e.reward_scale != 1.0;
  CHECK(scaled == 11);
  scaled = 0;
  for (auto* list : {&s["ML20"].train, &s["ML20"].test})
    for (auto& e : *list) scaled += e.reward_scale != 1.0;
  CHECK(scaled == 11);
}

TEST_CASE("suite packs: widths over both splits, one-hot width, slots spread", "[taskpack][suite]") {
  struct Want {
    const char* id;
    int obs_pad, act_pad, one_hot, ntrain, ntest;
  };
  for (const Want& w : {Want{"MT1", 422, 52, 4, 4, 4}, Want{"ML1", 422, 52, 0, 3, 1},
                        Want{"MT4", 446, 52, 4, 4, 4}, Want{"ML4", 446, 52, 0, 3, 1},
                        Want{"MT20", 446, 52, 20, 20, 20}, Want{"ML20", 446, 52, 0, 15, 5}}) {
    INFO("suite " << w.id);
    const Suite s = taskpack::load_suite(w.id);
    for (const char* split : {"train", "test"}) {
      const int n = std::string(split) == "train" ? w.ntrain : w.ntest;
      const auto p = taskpack::suite_pack(s, split, 2 * n + 1);
      CHECK(p.name == std::string(w.id) + "/" + split);
      CHECK(p.mode == s.mode);
      CHECK(p.obs_pad == w.obs_pad);  // the same for both splits
      CHECK(p.act_pad == w.act_pad);
      CHECK(p.one_hot == w.one_hot);
      REQUIRE(static_cast<int>(p.entries.size()) == n);
      int total = 0;
      for (int i = 0; i < n; ++i) {
        CHECK(p.entries[i].slots == (i == 0 ? 3 : 2));  // the first total % n entries get one more
        total += p.entries[i].slots;
        const auto& e = std::string(split) == "train" ? s.train[i] : s.test[i];
        CHECK(p.entries[i].task == e.task);
        CHECK(p.entries[i].label == e.label);
        CHECK(p.entries[i].config == e.config);
        CHECK(p.entries[i].reward_scale == e.reward_scale);
      }
      CHECK(total == 2 * n + 1);
    }
  }
  const Suite ml4 = taskpack::load_suite("ML4");
  CHECK(thrown<ConfigError>([&] { taskpack::suite_pack(ml4, "validation", 8); }).key() == "split");
  CHECK(thrown<ConfigError>([&] { taskpack::suite_pack(ml4, "train", 2); }).key() ==
        "total_slots");
}

TEST_CASE("MT1's goal variants put the goal where the suite says", "[taskpack][suite]") {
  const Suite mt1 = taskpack::load_suite("MT1");
  taskpack::PackOptions o;
  o.seed = 3;
  o.threads = 2;
  taskpack::TaskPack pack(taskpack::suite_pack(mt1, "train", 4), o);
  REQUIRE(pack.obs_dim() == 426);
  const std::map<std::string, std::array<float, 3>> want = {{"original", {0.f, -0.79f, 0.54f}},
                                                           {"left", {0.f, -0.84f, 0.54f}},
                                                           {"right", {0.05f, -0.79f, 0.54f}},
                                                           {"back", {-0.05f, -0.79f, 0.54f}}};
  std::mt19937_64 rng(2);
  std::vector<float> a(static_cast<size_t>(pack.nslot()) * pack.act_dim());
  for (int step = 0; step < 3; ++step) {
    for (int g = 0; g < 4; ++g) {
      INFO("variant " << pack.label(g) << ", step " << step);
      const auto& goal = pack.group(g).spec().obs.at("goal.pose");
      const float* row = pack.obs.data() + static_cast<size_t>(pack.group_begin(g)) * pack.obs_dim();
      const auto& w = want.at(pack.label(g));
      for (int k = 0; k < 3; ++k) CHECK(row[goal.start + k] == w[k]);
      CHECK(row[426 - 4 + g] == 1.f);  // its one-hot id
    }
    random_actions(a, rng);
    pack.step(a);
  }
  // ML1's test task: the goal is "back", and hidden from the observation
  const Suite ml1 = taskpack::load_suite("ML1");
  taskpack::TaskPack test(taskpack::suite_pack(ml1, "test", 1), o);
  REQUIRE(test.obs_dim() == 422);
  const auto& goal = test.group(0).spec().obs.at("goal.pose");
  for (int k = 0; k < 7; ++k) CHECK(test.obs[goal.start + k] == 0.f);
  const auto& g = test.group(0).slot_state(0).goal[0];
  CHECK(g[0] == Approx(-0.05));
  CHECK(g[1] == Approx(-0.79));
  CHECK(g[2] == Approx(0.54));
}

TEST_CASE("MT4 runs: hand over with free bases beside the other catch tasks", "[taskpack][suite]") {
  taskpack::PackOptions o;
  o.seed = 9;
  o.threads = 2;
  taskpack::TaskPack pack(taskpack::suite_pack(taskpack::load_suite("MT4"), "train", 4), o);
  REQUIRE(pack.obs_dim() == 450);
  REQUIRE(pack.act_dim() == 52);
  CHECK(pack.label(1) == "hand_over");
  CHECK(pack.group(1).spec().id == "hand_over_free");
  CHECK(pack.group(1).act_dim() == 52);
  // its YAML: hand_over's values, plus catch_underarm's base scales
  {
    const auto& v = dynamic_cast<const tasks::CatchTask&>(pack.group(1).task()).params();
    const auto ho_task = tasks::make_task("hand_over");
    const auto cu_task = tasks::make_task("catch_underarm");
    const auto& ho = dynamic_cast<const tasks::CatchTask&>(*ho_task).params();
    const auto& cu = dynamic_cast<const tasks::CatchTask&>(*cu_task).params();
    CHECK(v.episode_length == ho.episode_length);
    CHECK(v.right.pos == ho.right.pos);
    CHECK(v.left.pos == ho.left.pos);
    CHECK(v.left.rpy == ho.left.rpy);
    REQUIRE(v.objects.size() == 1);
    CHECK(v.objects[0].start == ho.objects[0].start);
    CHECK(v.objects[0].goal == ho.objects[0].goal);
    CHECK(v.object_position_noise == ho.object_position_noise);
    CHECK(v.hand_dof_noise == ho.hand_dof_noise);
    CHECK(v.dist_weight == ho.dist_weight);
    CHECK(v.success_tolerance == ho.success_tolerance);
    CHECK(v.goal_bonus == ho.goal_bonus);
    CHECK(v.drop_height == ho.drop_height);
    CHECK(v.force_scale == cu.force_scale);
    CHECK(v.torque_scale == cu.torque_scale);
    CHECK(v.force_scale > 0);
  }
  // the free bases move: pushing both bases up raises the base position in the observation
  const auto& base = pack.group(1).spec().obs.at("right.base_pos");
  const float z0 = pack.obs[static_cast<size_t>(1) * 450 + base.start + 2];
  std::vector<float> a(static_cast<size_t>(pack.nslot()) * 52, 0.f);
  const auto& act = pack.group(1).spec().act;
  for (int s = 0; s < pack.nslot(); ++s)  // every task here has this action layout
    for (const char* side : {"right", "left"})
      a[s * 52 + act.at(std::string(side) + ".base_translation").start + 2] = 1.f;  // force z
  // 83.3 N against the base damping moves a base 0.028 m/s, as the original's: 0.5 s, 14 mm
  for (int i = 0; i < 30; ++i) pack.step(a);
  const float z1 = pack.obs[static_cast<size_t>(1) * 450 + base.start + 2];
  CHECK(z1 > z0 + 0.005f);
  for (int s = 0; s < pack.nslot(); ++s) CHECK(pack.fault[s] == 0);
}

TEST_CASE("bad suite files are ConfigErrors naming the file and the key", "[taskpack][suite]") {
  TaskTempDir dir;
  const std::string good = R"(id: X1
description: a test suite
mode: meta
source: this test
train:
  - {task: catch_underarm}
  - {task: hand_over, label: ho, reward_scale: 0.5}
test:
  - {task: two_catch_underarm}
)";
  {
    const std::string f = dir.write("good.yaml", good);
    const Suite s = taskpack::load_suite(f);
    CHECK(s.id == "X1");
    CHECK(s.file == f);
    CHECK(labels_of(s.train) == Names{"catch_underarm", "ho"});
    CHECK(s.train[1].reward_scale == 0.5);
    CHECK(s.train[0].config.empty());
  }
  struct Bad {
    const char* what;
    std::string text;
    const char* key;
  };
  const std::vector<Bad> bad = {
      {"unknown top-level key", good + "colour: red\n", "colour"},
      {"unknown entry key", edit_once(good, "{task: catch_underarm}", "{task: catch_underarm, slots: 4}"),
       "train[0].slots"},
      {"unknown task", edit_once(good, "task: hand_over,", "task: hand_overr,"), "train[1].task"},
      {"duplicate label", edit_once(good, "label: ho", "label: catch_underarm"), "train[1]"},
      {"label reused by test", edit_once(good, "{task: two_catch_underarm}",
                                         "{task: two_catch_underarm, label: ho}"),
       "test[0]"},
      {"negative reward scale", edit_once(good, "0.5", "-0.5"), "train[1].reward_scale"},
      {"non-finite reward scale", edit_once(good, "0.5", ".nan"), "train[1].reward_scale"},
      {"non-numeric reward scale", edit_once(good, "0.5", "half"), "train[1].reward_scale"},
      {"missing train", good.substr(0, good.find("train:")) + "test: train\n", "train"},
      {"empty train", edit_once(good, "train:\n  - {task: catch_underarm}\n  - {task: hand_over, "
                                      "label: ho, reward_scale: 0.5}\n",
                                "train: []\n"),
       "train"},
      {"missing test", good.substr(0, good.find("test:")), "test"},
      {"bad mode", edit_once(good, "mode: meta", "mode: plain"), "mode"},
      {"multitask tested on a list", edit_once(good, "mode: meta", "mode: multitask"), "test"},
      {"missing config file", edit_once(good, "{task: catch_underarm}",
                                        "{task: catch_underarm, config: goals/none.yaml}"),
       "train[0].config"},
      {"missing description", edit_once(good, "description: a test suite\n", ""), "description"},
      {"goals without a goal_seed",
       edit_once(good, "{task: catch_underarm}",
                 "{task: catch_underarm, goals: {count: 2, half_extent: [0, 0, 0]}}"),
       "train[0].goals"},
      {"goals of a task without goals",
       edit_once(good, "train:\n  - {task: catch_underarm}",
                 "goal_seed: 1\ntrain:\n  - {task: door_open_outward, goals: "
                 "{count: 2, half_extent: [0, 0, 0]}}"),
       "train[0].goals"},
      {"no goals",
       edit_once(good, "train:\n  - {task: catch_underarm}",
                 "goal_seed: 1\ntrain:\n  - {task: catch_underarm, goals: "
                 "{count: 0, half_extent: [0, 0, 0]}}"),
       "train[0].goals.count"},
      {"negative half extent",
       edit_once(good, "train:\n  - {task: catch_underarm}",
                 "goal_seed: 1\ntrain:\n  - {task: catch_underarm, goals: "
                 "{count: 2, half_extent: [0, -1, 0]}}"),
       "train[0].goals.half_extent"},
  };
  for (const auto& b : bad) {
    INFO(b.what);
    const std::string f = dir.write("bad.yaml", b.text);
    const auto e = thrown<ConfigError>([&] { taskpack::load_suite(f); });
    INFO(e.what());
    CHECK(e.key() == b.key);
    CHECK(e.file().rfind(f, 0) == 0);  // the file, maybe with a line
  }
  // an unknown id, and an id that does not match its file
  CHECK(thrown<ConfigError>([] { taskpack::load_suite("MT7"); }).key() == "suite");
  const std::string renamed = dir.write("MT4.yaml", good);
  CHECK(taskpack::load_suite(renamed).id == "X1");  // by path: any id
}

TEST_CASE("ML1-goals: train and held-out test goals drawn from its seed, given to slots in turn",
          "[taskpack][suite][goals]") {
  const Suite s = taskpack::load_suite("ML1-goals");
  REQUIRE(s.train.size() == 1);
  REQUIRE(s.test.size() == 1);
  const auto& train = s.train[0].goals;
  const auto& test = s.test[0].goals;
  REQUIRE(train.size() == 40);
  REQUIRE(test.size() == 10);
  const double half[3] = {0.05, 0.05, 0.02};
  for (const auto* list : {&train, &test})
    for (const auto& g : *list)
      for (int k = 0; k < 3; ++k) CHECK(std::abs(g[k]) <= half[k]);
  // the held-out goals are new draws, and the draws fill the box
  for (const auto& t : test)
    for (const auto& g : train) CHECK(t != g);
  double lo = 1, hi = -1;
  for (const auto& g : train) lo = std::min(lo, g[0]), hi = std::max(hi, g[0]);
  CHECK(lo < -0.03);
  CHECK(hi > 0.03);
  // the same seed gives the same goals
  CHECK(taskpack::load_suite("ML1-goals").test[0].goals == test);

  // a pack of the test split: slot i's goal is the task's own goal plus test[i % 10], from the
  // first episode on; goal slices are zeroed in the rows (meta mode)
  const auto spec = taskpack::suite_pack(s, "test", 12);
  REQUIRE(spec.entries[0].goals == test);
  taskpack::PackOptions o;
  o.threads = 1;
  o.seed = 4;
  taskpack::TaskPack pack(spec, o);
  pack.reset();
  auto plain = make_env("catch_underarm", 1, 4, 1);
  const auto base = plain->slot_state(0).goal[0];
  for (int i = 0; i < 12; ++i) {
    const auto& goal = pack.group(0).slot_state(i).goal[0];
    for (int k = 0; k < 3; ++k) CHECK(goal[k] == Approx(base[k] + test[i % 10][k]).margin(1e-12));
  }
  const tasks::Slice* pose = pack.group(0).spec().obs.find("goal.pose");
  REQUIRE(pose);
  for (int k = 0; k < pose->size; ++k) CHECK(pack.obs[5 * pack.obs_dim() + pose->start + k] == 0);
}
