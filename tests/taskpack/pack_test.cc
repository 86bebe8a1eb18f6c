// taskpack::TaskPack: a task inside a pack steps bitwise as the task alone (observations,
// rewards x scale, flags, final observations, statistics); padding, one-hot ids, meta goal
// masks, ignored padded actions, reward scales; determinism for 1 and 2 threads; validation.
// Real MuJoCo scenes: few slots, tens of steps.
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "taskpack/pack.h"
#include "tests/tasks/task_fixture.h"

using namespace bidex;
using namespace bidex::test;
using taskpack::PackEntry;
using taskpack::PackMode;
using taskpack::PackSpec;
using taskpack::TaskPack;

namespace {

// A task YAML that is the task's own with a shorter episode (via `extends`), so that episodes
// end within a short test.
std::string short_episodes(const TaskTempDir& dir, const std::string& id, int length) {
  std::string text = "extends: ";
  text.append(tasks::default_task_config(id)).append("\nepisode_length: ");
  text.append(std::to_string(length)).append("\n");
  return dir.write(id + "_short.yaml", text);
}

std::unique_ptr<TaskPack> make_pack(const PackSpec& spec, uint64_t seed, int threads = 2) {
  taskpack::PackOptions o;
  o.seed = seed;
  o.threads = threads;
  return std::make_unique<TaskPack>(spec, o);
}

PackEntry entry(const std::string& task, int slots, double scale = 1.0,
                const std::string& config = "", const std::string& label = "") {
  PackEntry e;
  e.task = task;
  e.slots = slots;
  e.reward_scale = scale;
  e.config = config;
  e.label = label;
  return e;
}

bool same_bits(const float* a, const float* b, size_t n) {
  return std::memcmp(a, b, n * sizeof(float)) == 0;
}

// The pack's reward for a task reward r and scale k, as the pack computes it.
float scaled(float r, double k) { return static_cast<float>(static_cast<double>(r) * k); }

// Steps a pack and every entry's task alone (seed group_seed(seed, g), the same threads, the
// same configs) with the same random actions, and compares them slot by slot every step.
// Returns the number of episode ends seen.
int compare_with_alone(TaskPack& pack, uint64_t seed, int steps) {
  std::vector<std::unique_ptr<tasks::TaskEnv>> alone;
  for (int g = 0; g < pack.ngroups(); ++g)
    alone.push_back(make_env(pack.entry(g).task, pack.entry(g).slots,
                             taskpack::group_seed(seed, g), pack.threads(), pack.entry(g).config));
  std::mt19937_64 rng(99);
  std::vector<float> a(static_cast<size_t>(pack.nslot()) * pack.act_dim());
  int ends = 0;
  int64_t mismatches = 0;
  auto compare = [&](int step) {
    for (int g = 0; g < pack.ngroups(); ++g) {
      const tasks::TaskEnv& env = *alone[g];
      const size_t od = env.obs_dim();
      const double k = pack.entry(g).reward_scale;
      for (int l = 0; l < env.nslot(); ++l) {
        const int s = pack.group_begin(g) + l;
        INFO("step " << step << ", entry " << g << " (" << pack.label(g) << "), slot " << l);
        const float* prow = pack.obs.data() + static_cast<size_t>(s) * pack.obs_dim();
        const bool obs_ok = same_bits(prow, env.obs.data() + l * od, od);
        const bool flags_ok = pack.reward[s] == scaled(env.reward[l], k) &&
                              pack.terminated[s] == env.terminated[l] &&
                              pack.truncated[s] == env.truncated[l] &&
                              pack.success[s] == env.success[l] && pack.fault[s] == env.fault[l];
        bool final_ok = true;
        if (env.terminated[l] || env.truncated[l]) {
          ++ends;
          final_ok = same_bits(pack.final_obs.data() + static_cast<size_t>(s) * pack.obs_dim(),
                               env.final_obs.data() + l * od, od);
        }
        CHECK(obs_ok);
        CHECK(flags_ok);
        CHECK(final_ok);
        mismatches += !obs_ok + !flags_ok + !final_ok;
      }
    }
  };
  compare(0);
  for (int i = 1; i <= steps && mismatches == 0; ++i) {
    random_actions(a, rng, -1.3f, 1.3f);  // some out of range: both clip
    pack.step(a);
    for (int g = 0; g < pack.ngroups(); ++g) {
      // the task alone gets its own columns of its own rows
      const int ad = alone[g]->act_dim();
      std::vector<float> own(static_cast<size_t>(alone[g]->nslot()) * ad);
      for (int l = 0; l < alone[g]->nslot(); ++l)
        std::copy_n(a.data() + static_cast<size_t>(pack.group_begin(g) + l) * pack.act_dim(), ad,
                    own.data() + static_cast<size_t>(l) * ad);
      alone[g]->step(own);
    }
    compare(i);
  }
  // the same episodes in the statistics, unscaled
  auto stats = pack.take_stats();
  REQUIRE(stats.size() == alone.size());
  for (size_t g = 0; g < alone.size(); ++g) {
    auto st = alone[g]->take_stats();
    CHECK(stats[g].episodes == st.episodes);
    CHECK(stats[g].return_sum == st.return_sum);
    CHECK(stats[g].successes == st.successes);
    CHECK(stats[g].term_sums == st.term_sums);
  }
  return ends;
}

// Every result buffer of every step, as bytes.
std::vector<unsigned char> trajectory(TaskPack& pack, int steps, uint64_t action_seed) {
  std::vector<unsigned char> out;
  auto add = [&](const auto& v) {
    const auto* p = reinterpret_cast<const unsigned char*>(v.data());
    out.insert(out.end(), p, p + v.size() * sizeof(v[0]));
  };
  std::mt19937_64 rng(action_seed);
  std::vector<float> a(static_cast<size_t>(pack.nslot()) * pack.act_dim());
  add(pack.obs);
  for (int i = 0; i < steps; ++i) {
    random_actions(a, rng);
    pack.step(a);
    for (auto* v : {&pack.obs, &pack.final_obs, &pack.reward}) add(*v);
    for (auto* v : {&pack.terminated, &pack.truncated, &pack.success, &pack.fault}) add(*v);
  }
  return out;
}

}  // namespace

TEST_CASE("a task inside a mixed pack steps bitwise as the task alone", "[taskpack]") {
  TaskTempDir dir;
  PackSpec spec;
  spec.name = "mixed";
  spec.mode = PackMode::kMultiTask;
  spec.entries = {entry("catch_underarm", 3, 1.0, short_episodes(dir, "catch_underarm", 9)),
                  entry("lift_underarm", 2, 0.1, short_episodes(dir, "lift_underarm", 11)),
                  entry("hand_over", 2, 0.25, short_episodes(dir, "hand_over", 7))};
  auto pack = make_pack(spec, 31);
  REQUIRE(pack->nslot() == 7);
  REQUIRE(pack->ngroups() == 3);
  CHECK(pack->group_begin(2) == 5);  // hand_over sits at g = 2, slots 5 and 6
  CHECK(pack->group_of(4) == 1);
  CHECK(pack->group_of(5) == 2);
  CHECK(pack->obs_dim() == 428 + 3);
  CHECK(pack->act_dim() == 52);
  const int ends = compare_with_alone(*pack, 31, 24);
  CHECK(ends >= 7 * 2);  // every slot ended an episode at least twice
}

TEST_CASE("a one-entry plain pack is the task alone with the same seed", "[taskpack]") {
  TaskTempDir dir;
  PackSpec spec;
  spec.name = "catch_underarm";
  spec.entries = {entry("catch_underarm", 3, 1.0, short_episodes(dir, "catch_underarm", 8))};
  auto pack = make_pack(spec, 7);
  auto env = make_env("catch_underarm", 3, 7, pack->threads(), spec.entries[0].config);
  REQUIRE(pack->obs_dim() == env->obs_dim());
  REQUIRE(pack->act_dim() == env->act_dim());
  CHECK(pack->one_hot_offset() == -1);
  CHECK(taskpack::group_seed(7, 0) == 7);
  std::mt19937_64 rng(5);
  std::vector<float> a(static_cast<size_t>(3) * env->act_dim());
  int ends = 0;
  CHECK(pack->obs == env->obs);
  for (int i = 0; i < 20; ++i) {
    random_actions(a, rng);
    pack->step(a);
    env->step(a);
    INFO("step " << i);
    REQUIRE(same_bits(pack->obs.data(), env->obs.data(), env->obs.size()));
    REQUIRE(same_bits(pack->reward.data(), env->reward.data(), 3));
    REQUIRE(pack->terminated == env->terminated);
    REQUIRE(pack->truncated == env->truncated);
    for (int s = 0; s < 3; ++s)
      if (env->terminated[s] || env->truncated[s]) {
        ++ends;
        REQUIRE(same_bits(pack->final_obs.data() + s * env->obs_dim(),
                          env->final_obs.data() + s * env->obs_dim(), env->obs_dim()));
      }
  }
  CHECK(ends >= 3);
  // a reset starts every slot over, as the task's own reset
  pack->reset();
  env->reset();
  CHECK(same_bits(pack->obs.data(), env->obs.data(), env->obs.size()));
}

TEST_CASE("pack rows: zero padding and one one-hot id per row, in multi-task mode",
          "[taskpack]") {
  TaskTempDir dir;
  PackSpec spec;
  spec.name = "rows";
  spec.mode = PackMode::kMultiTask;
  spec.entries = {entry("hand_over", 2, 1.0, short_episodes(dir, "hand_over", 6)),
                  entry("two_catch_underarm", 2), entry("catch_underarm", 1)};
  auto pack = make_pack(spec, 3);
  const int pad = 446, n = 3;
  REQUIRE(pack->obs_dim() == pad + n);
  REQUIRE(pack->one_hot_offset() == pad);
  const int widths[] = {398, 446, 422};
  for (int g = 0; g < n; ++g) {
    const auto& keep = pack->obs_keep(g);
    REQUIRE(static_cast<int>(keep.size()) == pad);
    int kept = 0;
    for (int i = 0; i < pad; ++i) kept += keep[i];
    CHECK(kept == widths[g]);
    CHECK(keep[widths[g] - 1] == 1);
    CHECK(pack->label(g) == spec.entries[g].task);
  }
  auto check_rows = [&](const std::vector<float>& buf, int s) {
    const int g = pack->group_of(s);
    const float* row = buf.data() + static_cast<size_t>(s) * pack->obs_dim();
    int nonzero_pad = 0, ones = 0, others = 0;
    for (int i = widths[g]; i < pad; ++i) nonzero_pad += row[i] != 0.f;
    for (int i = 0; i < n; ++i) {
      ones += row[pad + i] == 1.f;
      others += row[pad + i] != 0.f && row[pad + i] != 1.f;
    }
    INFO("slot " << s << ", entry " << g);
    CHECK(nonzero_pad == 0);
    CHECK(ones == 1);
    CHECK(others == 0);
    CHECK(row[pad + g] == 1.f);  // at the entry's position
  };
  for (int s = 0; s < pack->nslot(); ++s) check_rows(pack->obs, s);
  std::mt19937_64 rng(8);
  std::vector<float> a(static_cast<size_t>(pack->nslot()) * pack->act_dim());
  int ends = 0;
  for (int i = 0; i < 8; ++i) {
    random_actions(a, rng);
    pack->step(a);
    for (int s = 0; s < pack->nslot(); ++s) {
      check_rows(pack->obs, s);
      if (pack->terminated[s] || pack->truncated[s]) {
        ++ends;
        check_rows(pack->final_obs, s);
      }
    }
  }
  CHECK(ends >= 2);  // hand_over's two slots ended an episode
  // the one-hot width may be wider than the entry count
  spec.one_hot = 5;
  spec.entries = {entry("hand_over", 1)};
  auto wide = make_pack(spec, 3, 1);
  CHECK(wide->obs_dim() == 398 + 5);
  CHECK(wide->obs[398] == 1.f);
  for (int i = 1; i < 5; ++i) CHECK(wide->obs[398 + i] == 0.f);
}

TEST_CASE("meta mode zeroes every goal slice and passes every other value through",
          "[taskpack]") {
  PackSpec plain;
  plain.name = "plain";
  plain.entries = {entry("catch_underarm", 2), entry("two_catch_underarm", 1),
                   entry("door_open_outward", 1)};
  PackSpec meta = plain;
  meta.name = "meta";
  meta.mode = PackMode::kMeta;
  auto p = make_pack(plain, 12);
  auto m = make_pack(meta, 12);
  REQUIRE(m->obs_dim() == p->obs_dim());
  REQUIRE(m->one_hot_offset() == -1);
  std::mt19937_64 rng(4);
  std::vector<float> a(static_cast<size_t>(p->nslot()) * p->act_dim());
  int64_t goal_values = 0, goal_nonzero_plain = 0, goal_nonzero_meta = 0, other_diff = 0;
  for (int i = 0; i <= 5; ++i) {
    if (i > 0) {
      random_actions(a, rng);
      p->step(a);
      m->step(a);
    }
    for (int s = 0; s < p->nslot(); ++s) {
      const int g = p->group_of(s);
      const auto& layout = p->group(g).spec().obs;
      std::vector<uint8_t> is_goal(static_cast<size_t>(p->obs_dim()), 0);
      for (const auto& sl : layout.slices())
        if (sl.goal) std::fill_n(is_goal.begin() + sl.start, sl.size, uint8_t{1});
      const float* pr = p->obs.data() + static_cast<size_t>(s) * p->obs_dim();
      const float* mr = m->obs.data() + static_cast<size_t>(s) * m->obs_dim();
      for (int k = 0; k < p->obs_dim(); ++k) {
        if (is_goal[k]) {
          ++goal_values;
          goal_nonzero_plain += pr[k] != 0.f;
          goal_nonzero_meta += mr[k] != 0.f;
          CHECK(m->obs_keep(g)[k] == 0);
        } else {
          other_diff += std::memcmp(pr + k, mr + k, sizeof(float)) != 0;
        }
      }
    }
    CHECK(m->reward == p->reward);
  }
  CHECK(goal_values > 0);
  CHECK(goal_nonzero_plain > 0);  // the mask hides values that are there
  CHECK(goal_nonzero_meta == 0);
  CHECK(other_diff == 0);
}

TEST_CASE("padded action columns are ignored, and rewards are the task's times the scale",
          "[taskpack]") {
  TaskTempDir dir;
  PackSpec spec;
  spec.name = "scales";
  spec.mode = PackMode::kMultiTask;
  spec.entries = {entry("hand_over", 2, 1.0, short_episodes(dir, "hand_over", 5)),
                  entry("catch_underarm", 2)};
  PackSpec scaled_spec = spec;
  scaled_spec.entries[0].reward_scale = 0.1;
  scaled_spec.entries[1].reward_scale = 2.5;
  auto clean = make_pack(spec, 21);
  auto garbage = make_pack(spec, 21);
  auto scaled_pack = make_pack(scaled_spec, 21);
  REQUIRE(clean->act_dim() == 52);
  std::mt19937_64 rng(6);
  std::vector<float> a(static_cast<size_t>(clean->nslot()) * clean->act_dim());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  int64_t rewards = 0;
  for (int i = 0; i < 12; ++i) {
    random_actions(a, rng);
    std::vector<float> b = a;
    for (int s = 0; s < 2; ++s)  // hand_over uses 40 of the 52 columns
      for (int k = 40; k < 52; ++k) b[s * 52 + k] = (k % 2) ? nan : 1e30f;
    clean->step(a);
    garbage->step(b);
    scaled_pack->step(a);
    INFO("step " << i);
    REQUIRE(same_bits(clean->obs.data(), garbage->obs.data(), clean->obs.size()));
    REQUIRE(same_bits(clean->reward.data(), garbage->reward.data(), clean->reward.size()));
    REQUIRE(clean->fault == garbage->fault);
    REQUIRE(clean->terminated == garbage->terminated);
    REQUIRE(clean->truncated == garbage->truncated);
    REQUIRE(same_bits(clean->obs.data(), scaled_pack->obs.data(), clean->obs.size()));
    for (int s = 0; s < clean->nslot(); ++s) {
      const double k = scaled_spec.entries[clean->group_of(s)].reward_scale;
      CHECK(scaled_pack->reward[s] == scaled(clean->reward[s], k));
      rewards += clean->reward[s] != 0.f;
    }
  }
  CHECK(rewards > 0);
  for (int s = 0; s < clean->nslot(); ++s) CHECK(garbage->fault[s] == 0);
  // statistics stay unscaled
  auto a1 = clean->take_stats(), a2 = scaled_pack->take_stats();
  CHECK(a1[0].episodes > 0);
  CHECK(a1[0].return_sum == a2[0].return_sum);
  CHECK(a1[1].return_sum == a2[1].return_sum);
}

TEST_CASE("a pack is bitwise deterministic for 1 and 2 threads", "[taskpack][determinism]") {
  TaskTempDir dir;
  PackSpec spec;
  spec.name = "det";
  spec.mode = PackMode::kMultiTask;
  spec.entries = {entry("catch_underarm", 3, 1.0, short_episodes(dir, "catch_underarm", 6)),
                  entry("hand_over", 2, 0.5), entry("door_open_outward", 2, 0.1)};
  auto one = make_pack(spec, 17, 1);
  auto two = make_pack(spec, 17, 2);
  CHECK(one->threads() == 1);
  CHECK(two->threads() == 2);
  const auto t1 = trajectory(*one, 14, 3);
  const auto t2 = trajectory(*two, 14, 3);
  REQUIRE(t1.size() == t2.size());
  CHECK(std::memcmp(t1.data(), t2.data(), t1.size()) == 0);
  // another seed differs
  auto other = make_pack(spec, 18, 2);
  const auto t3 = trajectory(*other, 1, 3);
  const auto t4 = trajectory(*make_pack(spec, 17, 2), 1, 3);
  REQUIRE(t3.size() == t4.size());
  CHECK(std::memcmp(t3.data(), t4.data(), t3.size()) != 0);
}

// Autoreset off (Gymnasium's NEXT_STEP and DISABLED modes from Python): a pack that resets its
// ended slots itself after each step runs bitwise as the pack that resets them within the step;
// a slot left ended is held (obs, no reward, no flags, no physics) and a late reset_slots gives
// the same first observation as the autoreset did.
TEST_CASE("with autoreset off, ended slots hold their final observation until reset_slots",
          "[taskpack]") {
  TaskTempDir dir;
  PackSpec spec;
  spec.name = "held";
  spec.mode = PackMode::kMultiTask;
  spec.entries = {entry("catch_underarm", 3, 1.0, short_episodes(dir, "catch_underarm", 5)),
                  entry("hand_over", 2, 0.5, short_episodes(dir, "hand_over", 4))};
  auto same = make_pack(spec, 23);
  auto next = make_pack(spec, 23);
  next->set_autoreset(false);
  CHECK_FALSE(next->autoreset());
  const int n = same->nslot(), od = same->obs_dim();
  std::mt19937_64 rng(9);
  std::vector<float> a(static_cast<size_t>(n) * same->act_dim());
  std::vector<uint8_t> ended(n);
  int ends = 0;
  for (int i = 0; i < 14; ++i) {
    random_actions(a, rng);
    same->step(a);
    next->step(a);
    INFO("step " << i);
    REQUIRE(same_bits(same->reward.data(), next->reward.data(), n));
    REQUIRE(same->terminated == next->terminated);
    REQUIRE(same->truncated == next->truncated);
    for (int s = 0; s < n; ++s) {
      ended[s] = same->terminated[s] || same->truncated[s];
      ends += ended[s];
      // the held pack's obs of an ended slot is its final observation
      const float* want = ended[s] ? same->final_obs.data() : same->obs.data();
      REQUIRE(same_bits(next->obs.data() + s * od, want + s * od, od));
      if (ended[s])
        REQUIRE(same_bits(next->final_obs.data() + s * od, same->final_obs.data() + s * od, od));
    }
    next->reset_slots(ended.data());
    REQUIRE(same_bits(next->obs.data(), same->obs.data(), same->obs.size()));
  }
  CHECK(ends >= n * 2);
  const auto s1 = same->take_stats(), s2 = next->take_stats();
  for (int g = 0; g < 2; ++g) {
    CHECK(s1[g].episodes == s2[g].episodes);
    CHECK(s1[g].return_sum == s2[g].return_sum);
  }

  // left ended: held for three steps, then reset late to the autoreset's first observation
  next->reset();
  same->reset();
  for (int i = 0; i < 4; ++i) {  // hand_over's episodes (4 steps) end at the fourth step
    random_actions(a, rng);
    same->step(a);
    next->step(a);
  }
  const int s = 3;  // hand_over's first slot
  REQUIRE(next->truncated[s]);
  REQUIRE(next->group(1).ended(0));
  REQUIRE_FALSE(next->group(0).ended(0));  // catch_underarm's episodes last 5 steps
  const std::vector<float> final_row(next->obs.begin() + s * od, next->obs.begin() + (s + 1) * od);
  const std::vector<float> first_row(same->obs.begin() + s * od, same->obs.begin() + (s + 1) * od);
  for (int i = 0; i < 3; ++i) {
    random_actions(a, rng);
    next->step(a);
    CHECK(next->reward[s] == 0.0f);
    CHECK_FALSE(next->terminated[s]);
    CHECK_FALSE(next->truncated[s]);
    CHECK(same_bits(next->obs.data() + s * od, final_row.data(), od));
  }
  std::vector<uint8_t> only(n, 0);
  only[s] = 1;
  const std::vector<float> others(next->obs.begin(), next->obs.begin() + s * od);
  next->reset_slots(only.data());
  CHECK(same_bits(next->obs.data() + s * od, first_row.data(), od));
  CHECK(same_bits(next->obs.data(), others.data(), others.size()));  // the others untouched
  CHECK(next->take_stats()[1].episodes == 2);  // each hand_over slot's episode counted once
}

TEST_CASE("invalid pack entries are ConfigErrors naming the entry", "[taskpack]") {
  auto error = [](const PackSpec& spec) {
    return thrown<ConfigError>([&] { make_pack(spec, 1, 1); });
  };
  PackSpec ok;
  ok.name = "bad";
  ok.mode = PackMode::kMultiTask;
  ok.entries = {entry("catch_underarm", 1), entry("hand_over", 1)};
  {
    PackSpec s = ok;
    s.entries[1].task = "hand_overr";
    auto e = error(s);
    CHECK(e.key() == "entries[1].task");
    CHECK(e.file() == "bad");
    CHECK(contains(e.expected(), "hand_over_free"));  // lists the known ids, variants too
  }
  {
    PackSpec s = ok;
    s.entries[0].slots = 0;
    CHECK(error(s).key() == "entries[0].slots");
  }
  for (double k : {-0.5, std::numeric_limits<double>::quiet_NaN(),
                   std::numeric_limits<double>::infinity()}) {
    PackSpec s = ok;
    s.entries[1].reward_scale = k;
    CHECK(error(s).key() == "entries[1].reward_scale");
  }
  {
    PackSpec s = ok;
    s.obs_pad = 400;  // catch_underarm has 422
    auto e = error(s);
    CHECK(e.key() == "obs_pad");
    CHECK(contains(e.expected(), "entries[0] (catch_underarm)"));
    s.obs_pad = 0;
    s.act_pad = 40;
    e = error(s);
    CHECK(e.key() == "act_pad");
    CHECK(contains(e.expected(), "entries[0]"));
  }
  {
    PackSpec s = ok;
    s.one_hot = 1;
    CHECK(error(s).key() == "one_hot");
  }
  {
    PackSpec s = ok;
    s.entries[1].task = "catch_underarm";  // same task twice: labels must tell them apart
    auto e = error(s);
    CHECK(e.key() == "entries[1].label");
    CHECK(contains(e.actual(), "catch_underarm"));
    s.entries[1].label = "second";
    CHECK_NOTHROW(make_pack(s, 1, 1));
  }
  {
    PackSpec s = ok;
    s.entries.clear();
    CHECK(error(s).key() == "entries");
  }
  // a wrong action count
  auto p = make_pack(ok, 1, 1);
  CHECK_THROWS_AS(p->step(std::vector<float>(3)), Error);
}

// The physics' load that training logs (metrics.csv: efc_rows, solver_iters): per slot and
// control step, the constraint rows at the step's end and the solver's iterations, as MuJoCo's
// own data of each slot holds them after the step, over every entry.
TEST_CASE("a pack's physics load is the mean of its slots' constraint rows and solver iterations",
          "[taskpack]") {
  PackSpec spec;
  spec.name = "two";
  spec.entries = {entry("catch_underarm", 3), entry("push_block", 2)};
  auto pack = make_pack(spec, 11);
  const auto before = pack->take_load();  // nothing stepped since the pack was built
  CHECK((std::isnan(before.rows) && std::isnan(before.iterations)));
  std::vector<float> a(static_cast<size_t>(pack->nslot()) * pack->act_dim(), 0.0f);
  double rows = 0, iters = 0;
  const int steps = 6;
  for (int i = 0; i < steps; ++i) {
    pack->step(a);
    for (int g = 0; g < pack->ngroups(); ++g)
      for (int s = 0; s < pack->group_slots(g); ++s) {
        // no episode ended, so each slot's data is still the step's
        REQUIRE(!pack->terminated[pack->group_begin(g) + s]);
        const mjData* d = pack->group(g).batch().data(s);
        rows += d->nefc;
        iters += sim::solver_iterations(d);
      }
  }
  const auto load = pack->take_load();
  CHECK(load.rows == Approx(rows / (steps * pack->nslot())));
  CHECK(load.iterations == Approx(iters / (steps * pack->nslot())));
  CHECK(load.rows > 10);  // hands on the table and an object in a palm make contacts
  CHECK(load.iterations >= 1);
  const auto again = pack->take_load();  // no step since the last call
  CHECK((std::isnan(again.rows) && std::isnan(again.iterations)));
  pack->step(a);
  CHECK(std::isfinite(pack->take_load().rows));
}
