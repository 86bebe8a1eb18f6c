// Task stages on the GPU backend, run on Warp's CPU device: the same per-world functions the
// CUDA kernels run, over the backend's float32 arrays, against TaskEnv on the CPU batch.
#include "tasks/warp_env.h"

#include <cmath>
#include <limits>

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
