// Task stages on the GPU backend, run on Warp's CPU device: the same per-world functions the
// CUDA kernels run, over the backend's float32 arrays, against TaskEnv on the CPU batch.
#include "tasks/warp_env.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <catch2/catch.hpp>

#include "tasks/registry.h"
#include "tests/fixture.h"

namespace bidex::tasks {
namespace {

EnvOptions cpu_env(int n, uint64_t seed) {
  EnvOptions o;
  o.nslot = n;
  o.threads = 1;
  o.seed = seed;
  o.physics_file = test::same_step_physics_file();
  return o;
}

WarpEnvOptions cpu_warp(int n, uint64_t seed) {
  WarpEnvOptions o;
  o.nslot = n;
  o.seed = seed;
  o.device = "cpu";
  o.physics_file = test::same_step_physics_file();  // compared step by step with TaskEnv
  return o;
}

double max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(double(a[i]) - double(b[i])));
  return m;
}

}  // namespace

TEST_CASE("WarpTaskEnv resets like TaskEnv: same streams, same first observations", "[warp]") {
  // one task of each family on the GPU path
  for (const char* id : {"catch_underarm", "door_open_outward", "push_block", "re_orientation",
                         "pen", "pour_water"}) {
    INFO(id);
    TaskEnv cpu(make_task(id, ""), cpu_env(4, 3));
    WarpTaskEnv gpu(make_task(id, ""), cpu_warp(4, 3));
    REQUIRE(gpu.obs_dim() == cpu.obs_dim());
    // the reset draws (hand joint noise, object pose and goal) come from the same keyed
    // streams on both; float32 state gives differences of float rounding only
    // except the fingertip force sensors: the GPU's position pass after a reset computes poses
    // and velocities, not forces (zero until the first step), where the CPU runs mj_forward
    std::vector<float> go = gpu.download<float>("obs"), co = cpu.obs;
    const int od = gpu.obs_dim();
    for (const char* name : {"right.fingertip_force", "left.fingertip_force"}) {
      const Slice* sl = gpu.spec().obs.find(name);
      REQUIRE(sl);
      for (int w = 0; w < 4; ++w)
        for (int k = 0; k < sl->size; ++k) {
          CHECK(go[w * od + sl->start + k] == 0.0f);
          go[w * od + sl->start + k] = co[w * od + sl->start + k] = 0.0f;
        }
    }
    CHECK(max_abs_diff(go, co) < 5e-4);  // 2e-4 seen: float32 positions of the doors
  }
}

TEST_CASE("WarpTaskEnv keeps re_orientation's curriculum levels as TaskEnv does", "[warp]") {
  // the levels live in the slot states on the device: the same goals at a reset, the same
  // levels in the stats, one reset later both lowered by `down`
  test::TempDir dir;
  const std::string file = dir.file("curriculum.yaml");
  std::ofstream(file) << "extends: " << BIDEX_SOURCE_DIR
                      << "/tasks/re_orientation/re_orientation.yaml\n"
                         "curriculum: {enabled: true, start: 0.3, up: 0.02, down: 0.05}\n";
  TaskEnv cpu(make_task("re_orientation", file), cpu_env(4, 3));
  WarpTaskEnv gpu(make_task("re_orientation", file), cpu_warp(4, 3));
  const Slice* goal = gpu.spec().obs.find("goal1.pose");
  REQUIRE(goal);
  for (int round = 0; round < 2; ++round) {
    if (round > 0) {
      cpu.reset();
      gpu.reset();
    }
    const auto go = gpu.download<float>("obs");
    const int od = gpu.obs_dim();
    for (int w = 0; w < 4; ++w)
      for (int k = 0; k < goal->size; ++k)
        CHECK(go[w * od + goal->start + k] ==
              Approx(cpu.obs[w * od + goal->start + k]).margin(1e-5));
    const EpisodeStats a = cpu.take_stats(), b = gpu.take_stats();
    CHECK(a.levels == 4);
    CHECK(b.levels == 4);
    CHECK(a.level_sum == Approx(4 * (0.3 - 0.05 * round)).epsilon(1e-12));
    CHECK(b.level_sum == Approx(a.level_sum).epsilon(1e-12));
  }
  // set from outside, as on the CPU
  cpu.set_levels(0.8);
  gpu.set_levels(0.8);
  cpu.reset();
  gpu.reset();
  CHECK(gpu.take_stats().level_sum == Approx(4 * 0.75).epsilon(1e-12));
  CHECK(cpu.take_stats().level_sum == Approx(4 * 0.75).epsilon(1e-12));
  CHECK_THROWS_WITH(gpu.set_levels(-0.1), Catch::Contains("[0, 1]"));
  // no curriculum: no levels
  TaskEnv plain(make_task("re_orientation", ""), cpu_env(2, 3));
  CHECK(plain.take_stats().levels == 0);
}

TEST_CASE("WarpTaskEnv takes per-slot goal shifts like TaskEnv", "[warp]") {
  TaskEnv cpu(make_task("two_catch_underarm", ""), cpu_env(3, 5));
  WarpTaskEnv gpu(make_task("two_catch_underarm", ""), cpu_warp(3, 5));
  REQUIRE(gpu.spec().goal_shifts == 2);
  const std::vector<double> shift = {0.1, 0, 0, 0, 0.05, 0, 0, 0, -0.02, 0.03, 0.03, 0.03};
  cpu.set_goal_shifts({0, 2}, shift);
  gpu.set_goal_shifts({0, 2}, shift);
  cpu.reset();
  gpu.reset();
  const int od = gpu.obs_dim();
  const std::vector<float> go = gpu.download<float>("obs");
  for (const char* name : {"goal1.pose", "goal2.pose"}) {
    const Slice* sl = gpu.spec().obs.find(name);
    REQUIRE(sl);
    for (int w = 0; w < 3; ++w)
      for (int k = 0; k < 3; ++k)
        CHECK(go[w * od + sl->start + k] == Approx(cpu.obs[w * od + sl->start + k]).margin(1e-5));
  }
  // slot 0's first goal moved 0.1 in x against slot 1's
  const Slice* g1 = gpu.spec().obs.find("goal1.pose");
  CHECK(go[g1->start] - go[od + g1->start] == Approx(0.1).margin(1e-5));
  CHECK_THROWS_AS(gpu.set_goal_shifts({3}, std::vector<double>(6, 0.0)), Error);
}

TEST_CASE("WarpTaskEnv steps, rewards and finishes episodes like TaskEnv", "[warp]") {
  TaskEnv cpu(make_task("catch_underarm", ""), cpu_env(3, 5));
  WarpTaskEnv gpu(make_task("catch_underarm", ""), cpu_warp(3, 5));
  std::vector<float> zero(3 * cpu.act_dim(), 0.0f);
  for (int t = 0; t < 3; ++t) {
    cpu.step(zero);
    gpu.step(zero);
  }
  // a few steps in, the egg falling through the same states: rewards agree closely
  const auto r = gpu.download<float>("reward");
  for (int w = 0; w < 3; ++w) CHECK(std::abs(r[w] - cpu.reward[w]) < 1e-3);
  CHECK(max_abs_diff(gpu.download<float>("obs"), cpu.obs) < 2e-3);
  // to the end of the first episodes (75 steps, or the egg's fall)
  for (int t = 3; t < 80; ++t) {
    cpu.step(zero);
    gpu.step(zero);
  }
  const EpisodeStats sc = cpu.take_stats(), sg = gpu.take_stats();
  CHECK(sg.episodes == sc.episodes);
  CHECK(sg.episodes >= 3);
  CHECK(sg.terminated + sg.truncated == sg.episodes);
  CHECK(sg.faults == 0);
  CHECK(std::abs(sg.return_sum - sc.return_sum) < 0.05 * std::abs(sc.return_sum) + 0.5);
  CHECK(sg.length_sum == Approx(sc.length_sum).margin(3));
  // taken: the next take starts from zero
  CHECK(gpu.take_stats().episodes == 0);
}

TEST_CASE("WarpTaskEnv pays the doors', the switch's and pour_water's reward variants as TaskEnv does",
          "[warp]") {
  // the same stage bodies with float rows. The two backends' physics differ by a little
  // (hand-distance terms by up to about 0.01 a step here), so each backend is checked against
  // itself: the reward does not act on the physics, so two variants of a task under the same
  // actions see the same states, and their rewards differ by what the variants' terms say,
  // worked out here from the observed handle points. Doors: the default with its gate opened
  // (goal_gate 0) pays 6 (door_close_outward; 2 for door_open_inward) + the goal on the
  // handles' y-distance, the paper 0.2 + the goal on their distance. Switch: the paper's
  // 50 (1.4 - d) against the default's 50 (0.045 - d), 67.75 more a step. pour_water, its gate
  // opened (10 m): bidex's 10 (0.5 - d) + 20 min(h, 0.05) against the paper's 2 (0.5 - d), about
  // 3.2 more a step with the spout 0.1 m from the opening; the same difference on both backends.
  test::TempDir dir;
  auto yaml = [&](const std::string& id, const std::string& reward) {
    const std::string file = dir.file(id + "-" + std::to_string(dir.list().size()) + ".yaml");
    std::ofstream(file) << "extends: " << BIDEX_SOURCE_DIR << "/tasks/" << id << "/" << id
                        << ".yaml\nreward: " << reward << "\n";
    return file;
  };
  struct Case {
    std::string id, a, b;  // task; YAMLs of the two variants
    bool open;             // door goal: open (2 gap) or close (1 - 2 gap, 2 (1 - gap))
    double constant;       // the default's constant (doors)
  };
  const std::vector<Case> cases = {
      {"door_close_outward", yaml("door_close_outward", "{goal_gate: 0}"),
       yaml("door_close_outward", "{variant: paper}"), false, 6},
      {"door_open_inward", yaml("door_open_inward", "{goal_gate: 0}"),
       yaml("door_open_inward", "{variant: paper}"), true, 2},
      {"switch", "", yaml("switch", "{variant: paper}"), false, 0},
      {"pour_water", yaml("pour_water", "{gate: 10}"),
       yaml("pour_water", "{variant: paper, gate: 10}"), false, 0}};
  // the expected reward difference a - b of world w from its observation (doors)
  auto door_diff = [](const Case& c, const TaskEnv& env, const float* o) {
    const float* r = o + env.spec().obs.at("right_handle.pos").start;
    const float* l = o + env.spec().obs.at("left_handle.pos").start;
    const double dx = r[0] - l[0], dy = r[1] - l[1], dz = r[2] - l[2];
    const double gap_y = std::abs(dy), gap = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double goal_a = c.open ? 2 * gap_y : 1 - 2 * gap_y;
    const double goal_b = c.open ? 2 * gap : 2 * (1 - gap);
    return (c.constant - 0.2) + goal_a - goal_b;
  };
  for (const auto& c : cases) {
    INFO(c.id);
    TaskEnv cpu_a(make_task(c.id, c.a), cpu_env(2, 7)), cpu_b(make_task(c.id, c.b), cpu_env(2, 7));
    WarpTaskEnv gpu_a(make_task(c.id, c.a), cpu_warp(2, 7));
    WarpTaskEnv gpu_b(make_task(c.id, c.b), cpu_warp(2, 7));
    const int od = cpu_a.obs_dim();
    std::vector<float> zero(2 * cpu_a.act_dim(), 0.0f);
    for (int t = 0; t < 4; ++t) {
      for (auto* e : {&cpu_a, &cpu_b}) e->step(zero);
      for (auto* e : {&gpu_a, &gpu_b}) e->step(zero);
      const auto ra = gpu_a.download<float>("reward"), rb = gpu_b.download<float>("reward");
      const auto og = gpu_a.download<float>("obs");
      for (int w = 0; w < 2; ++w) {
        INFO("step " << t << ", world " << w << ": cpu " << cpu_a.reward[w] << " / "
                     << cpu_b.reward[w] << ", gpu " << ra[w] << " / " << rb[w]);
        if (c.id == "pour_water") {
          const double cpu_diff = double(cpu_a.reward[w]) - cpu_b.reward[w];
          CHECK(cpu_diff > 2.5);  // 8 (0.5 - d) with d near 0.1, and the lift
          CHECK(double(ra[w]) - rb[w] == Approx(cpu_diff).margin(0.02));
          continue;
        }
        const bool sw = c.id == "switch";
        const double want_cpu = sw ? -67.75 : door_diff(c, cpu_a, &cpu_a.obs[w * od]);
        const double want_gpu = sw ? -67.75 : door_diff(c, cpu_a, &og[w * od]);
        CHECK(double(cpu_a.reward[w]) - cpu_b.reward[w] == Approx(want_cpu).margin(1e-4));
        CHECK(double(ra[w]) - rb[w] == Approx(want_gpu).margin(1e-4));
        CHECK(std::abs(ra[w] - cpu_a.reward[w]) < 0.05);  // the physics' difference only
      }
    }
  }
}

TEST_CASE("WarpTaskEnv ends a faulted world's episode, resets it alone, keeps stepping",
          "[warp]") {
  WarpTaskEnv gpu(make_task("hand_over", ""), cpu_warp(3, 1));
  std::vector<float> a(3 * gpu.act_dim(), 0.0f);
  a[1 * gpu.act_dim() + 4] = std::numeric_limits<float>::quiet_NaN();
  gpu.step(a);
  const auto faulted = gpu.download<uint8_t>("faulted");
  const auto truncated = gpu.download<uint8_t>("truncated");
  CHECK(faulted == std::vector<uint8_t>{0, 1, 0});
  CHECK(truncated == std::vector<uint8_t>{0, 1, 0});
  const auto fo = gpu.download<float>("final_obs");
  for (int i = 0; i < gpu.obs_dim(); ++i) CHECK(fo[gpu.obs_dim() + i] == 0.0f);
  for (float x : gpu.download<float>("obs")) CHECK(std::isfinite(x));
  std::fill(a.begin(), a.end(), 0.0f);
  gpu.step(a);
  CHECK(gpu.download<uint8_t>("faulted") == std::vector<uint8_t>{0, 0, 0});
  const EpisodeStats st = gpu.take_stats();
  CHECK(st.episodes == 1);
  CHECK(st.faults == 1);
}

TEST_CASE("WarpTaskEnv faults a world whose observation is not finite, as TaskEnv does",
          "[warp][faults]") {
  // world 1's goal a finite 1e39 m away: past float, so its observed goal is infinite on both
  // paths; the row is cleared and the world faults at every next step, the others never
  TaskEnv cpu(make_task("catch_underarm", ""), cpu_env(3, 6));
  WarpTaskEnv gpu(make_task("catch_underarm", ""), cpu_warp(3, 6));
  cpu.set_goal_shifts({1}, {1e39, 0, 0});
  gpu.set_goal_shifts({1}, {1e39, 0, 0});
  cpu.reset();
  gpu.reset();
  std::vector<float> zero(3 * gpu.act_dim(), 0.0f);
  for (int t = 0; t < 3; ++t) {
    cpu.step(zero);
    gpu.step(zero);
    CHECK(gpu.download<uint8_t>("faulted") == std::vector<uint8_t>{0, 1, 0});
    CHECK(cpu.fault == std::vector<uint8_t>{0, 1, 0});
    CHECK(gpu.download<float>("reward")[1] == 0.0f);
    for (const char* name : {"obs", "final_obs", "reward", "terms"})
      for (float x : gpu.download<float>(name)) CHECK(std::isfinite(x));
  }
  const EpisodeStats sc = cpu.take_stats(), sg = gpu.take_stats();
  CHECK(sg.faults == 3);
  CHECK(sc.faults == 3);
  CHECK(sg.episodes == 3);
  CHECK(gpu.backend().total_faults() == 0);  // the physics never faulted
}

TEST_CASE("WarpTaskEnv runs every registered task", "[warp]") {
  std::vector<std::string> ids;
  for (const auto* reg : {&task_registry(), &variant_registry()})
    for (const TaskEntry& e : *reg) ids.push_back(e.spec().id);
  CHECK(ids.size() == 22);
  for (const std::string& id : ids) {
    INFO(id);
    WarpTaskEnv gpu(make_task(id, ""), cpu_warp(1, 1));
    CHECK(gpu.obs_dim() == gpu.spec().obs.dim());
  }
}

}  // namespace bidex::tasks
