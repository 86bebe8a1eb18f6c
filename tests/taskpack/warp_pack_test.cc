// The pack on the GPU backend, run on Warp's CPU device: its padded, one-hot rows against the
// CPU pack's, its done and bootstrap rows at a time limit, the collector reading its rows in
// place, and a training run on the GPU path's code (bidex train --device warp-cpu).
#include "tests/rl/rl_fixture.h"

#include <cmath>
#include <cstring>
#include <random>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "rl/collector.h"
#include "rl/metrics.h"
#include "sim/cuda_driver.h"
#include "taskpack/warp_pack.h"
#include "tests/fixture.h"

using namespace bidex;

namespace {

taskpack::PackSpec two_tasks() {
  // two families, two widths, a reward scale: multi-task rows with padding and one-hot ids
  taskpack::PackSpec spec;
  spec.name = "two";
  spec.mode = taskpack::PackMode::kMultiTask;
  taskpack::PackEntry a, b;
  a.task = "catch_underarm_raise";
  a.slots = 2;
  a.reward_scale = 2.0;
  b.task = "push_block";
  b.slots = 3;
  spec.entries = {a, b};
  return spec;
}

taskpack::WarpPackOptions on_warp_cpu(uint64_t seed) {
  taskpack::WarpPackOptions o;
  o.seed = seed;
  o.device = "cpu";
  o.physics_file = test::same_step_physics_file();  // compared step by step with the CPU pack
  return o;
}

// zeroes the fingertip force columns: after a reset the GPU's position pass computes no forces
// (sim/README.md), where the CPU runs mj_forward
void drop_forces(const taskpack::Pack& p, std::vector<float>& rows) {
  for (int g = 0; g < p.ngroups(); ++g)
    for (const char* name : {"right.fingertip_force", "left.fingertip_force"})
      if (const tasks::Slice* sl = p.task_spec(g).obs.find(name))
        for (int s = p.group_begin(g); s < p.group_begin(g) + p.group_slots(g); ++s)
          for (int k = 0; k < sl->size; ++k) rows[size_t(s) * p.obs_dim() + sl->start + k] = 0;
}

}  // namespace

TEST_CASE("a GPU pack writes the CPU pack's padded, one-hot, scaled rows", "[warp][taskpack]") {
  const taskpack::PackSpec spec = two_tasks();
  taskpack::PackOptions po;
  po.threads = 1;
  po.seed = 11;
  po.physics_file = test::same_step_physics_file();
  taskpack::TaskPack cpu(spec, po);
  taskpack::WarpPack gpu(spec, on_warp_cpu(11));
  REQUIRE(gpu.nslot() == 5);
  REQUIRE(gpu.obs_dim() == cpu.obs_dim());
  REQUIRE(gpu.act_dim() == cpu.act_dim());
  CHECK(gpu.device() == "cpu");
  CHECK_FALSE(gpu.on_gpu());

  const int D = gpu.obs_dim();
  std::vector<float> go = gpu.download("obs"), co = cpu.obs;
  // padding is exactly zero and each slot carries exactly its entry's bit
  for (int s = 0; s < gpu.nslot(); ++s) {
    const int g = gpu.group_of(s);
    const int own = gpu.task_spec(g).obs.dim();
    for (int k = own; k < gpu.obs_pad(); ++k) CHECK(go[size_t(s) * D + k] == 0.f);
    for (int h = 0; h < gpu.ngroups(); ++h)
      CHECK(go[size_t(s) * D + gpu.obs_pad() + h] == (h == g ? 1.f : 0.f));
  }
  // the same reset draws on both paths: rows agree to float rounding
  drop_forces(gpu, go);
  drop_forces(cpu, co);
  double diff = 0;
  size_t at = 0;
  for (size_t i = 0; i < go.size(); ++i)
    if (std::abs(go[i] - co[i]) > diff) diff = std::abs(go[i] - co[i]), at = i;
  INFO("slot " << at / D << " column " << at % D);
  CHECK(diff < 5e-4);
  CHECK(gpu.download("done") == std::vector<float>(5, 0.f));

  const std::vector<float> zero(size_t(gpu.nslot()) * gpu.act_dim(), 0.f);
  for (int t = 0; t < 3; ++t) {
    cpu.step(zero);
    gpu.step(zero);
  }
  // rewards: exactly the entry's task reward times its scale; near the CPU pack's (float32
  // MuJoCo Warp against double MuJoCo: push_block's table contacts differ by under 0.5% after
  // three steps)
  const std::vector<float> r = gpu.download("reward");
  for (int g = 0; g < gpu.ngroups(); ++g) {
    const auto own = gpu.group(g).download<float>("reward");
    for (int l = 0; l < gpu.group_slots(g); ++l) {
      const int s = gpu.group_begin(g) + l;
      CHECK(r[s] == static_cast<float>(double(own[l]) * gpu.entry(g).reward_scale));
      CHECK(std::abs(r[s] - cpu.reward[s]) < 1e-2 * std::max(1.f, std::abs(cpu.reward[s])));
    }
  }
  // each entry read its own columns of the padded action rows: nothing faulted
  CHECK(gpu.total_faults() == 0);
  CHECK(gpu.room_advice().empty());
  int most = 0;
  for (const auto& rows : gpu.rows()) {
    CHECK(rows.needed > 0);
    CHECK(rows.needed <= rows.room);
    most = std::max(most, rows.needed);
  }
  // the physics' load per slot-step on both paths (training logs it): constraint rows within
  // the most any world needed, and solver iterations; the rows near the CPU pack's (the contacts
  // of float32 MuJoCo Warp and double MuJoCo differ a little)
  const auto gl = gpu.take_load(), cl = cpu.take_load();
  INFO("rows " << gl.rows << " and " << cl.rows << ", iterations " << gl.iterations << " and "
               << cl.iterations);
  CHECK((gl.rows > 0 && gl.rows <= most));
  CHECK(gl.rows == Approx(cl.rows).epsilon(0.2));
  CHECK(gl.iterations >= 1);
  CHECK(std::isnan(gpu.take_load().rows));  // no step since
}

TEST_CASE("the collector reads a GPU pack's rows in place, with the time limit's final rows",
          "[warp][rl][collector]") {
  // catch_underarm_raise: 40-step episodes; zero actions keep the egg on the palm, so every
  // slot is cut by the time limit at step 40 and none before
  taskpack::PackSpec spec;
  spec.name = "one";
  taskpack::PackEntry e;
  e.task = "catch_underarm_raise";
  e.slots = 3;
  spec.entries.push_back(e);
  taskpack::WarpPack pack(spec, on_warp_cpu(5));
  auto collector = rl::make_collector(pack, torch::Device(torch::kCPU));
  const int N = pack.nslot(), D = pack.obs_dim();
  torch::Tensor obs = collector->reset();
  REQUIRE(obs.sizes() == torch::IntArrayRef({N, D}));
  CHECK(obs[1][7].item<float>() == pack.download("obs")[size_t(1) * D + 7]);
  const auto zero = torch::zeros({N, pack.act_dim()});
  for (int step = 1; step <= 40; ++step) {
    const rl::Transition t = collector->step(zero);
    const std::vector<float> rew = pack.download("reward");
    for (int s = 0; s < N; ++s) CHECK(t.reward[s].item<float>() == rew[s]);
    if (step < 40) {
      CHECK(t.done.sum().item<float>() == 0.f);
      CHECK(t.final_ids.numel() == 0);
    } else {
      CHECK(t.done.sum().item<float>() == float(N));
      REQUIRE(t.final_ids.numel() == N);
      const std::vector<float> fin = pack.download("final_obs");
      for (int j = 0; j < N; ++j) {
        const int64_t s = t.final_ids[j].item<int64_t>();
        CHECK(s == j);
        for (int k : {0, 5, D - 1}) CHECK(t.final_obs[j][k].item<float>() == fin[s * D + k]);
        CHECK(t.obs[s].equal(t.final_obs[j]) == false);  // it goes on from its reset state
      }
    }
  }
  // the transitions are copies: the next step does not change them
  const rl::Transition a = collector->step(zero);
  const torch::Tensor kept = a.obs.clone();
  collector->step(zero);
  CHECK(a.obs.equal(kept));
  CHECK(collector->take_sim_seconds() > 0);
  std::vector<tasks::EpisodeStats> st = pack.take_stats();
  CHECK(st[0].episodes == N);
  CHECK(st[0].truncated == N);
}

TEST_CASE("training runs on the GPU path's code, records its device and resumes on the CPU",
          "[warp][rl][train]") {
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  // 4 slots x 8 steps per update: 3 updates
  const std::string yaml = test::tiny_yaml("catch_underarm_raise", {"train.steps=96"});
  rl::TrainOptions o = test::quiet();
  o.device = "warp-cpu";
  o.profile = true;
  o.stop_after_updates = 2;
  const rl::TrainResult r = rl::train_new(yaml, dir, o);
  CHECK(r.updates == 2);
  CHECK(r.sim_device == "warp-cpu");
  CHECK(r.room_advice.empty());
  // the summary keeps how close the worlds came to their room
  const auto summary = nlohmann::json::parse(read_file(dir + "/summary.json"));
  REQUIRE(summary["gpu_rows"].size() == 1);
  CHECK(summary["gpu_rows"][0]["label"] == "catch_underarm_raise");
  CHECK(summary["gpu_rows"][0]["rows_needed"].get<int>() > 0);
  CHECK(summary["gpu_rows"][0]["rows_needed"].get<int>() <= summary["gpu_rows"][0]["njmax"].get<int>());
  const auto run = nlohmann::json::parse(read_file(dir + "/run.json"));
  CHECK(run["sessions"][0]["sim_device"] == "warp-cpu");
  // every update logs the physics' load per slot-step, from the backend's sums
  {
    std::vector<std::string> cols;
    std::vector<std::vector<double>> rows;
    rl::parse_metrics_csv(read_file(dir + "/metrics.csv"), dir, cols, rows);
    for (const char* name : {"efc_rows", "solver_iters"}) {
      const auto c = std::find(cols.begin(), cols.end(), name) - cols.begin();
      REQUIRE(c < static_cast<long>(cols.size()));
      for (const auto& row : rows) CHECK((std::isfinite(row[c]) && row[c] > 0));
    }
  }
  const auto prof = nlohmann::json::parse(read_file(dir + "/profile.json"));
  CHECK(prof["slot_steps"] == 64);
  for (const char* k : {"simulation", "physics", "task_kernels", "policy", "update"})
    CHECK(prof["seconds"][k].get<double>() >= 0);
  CHECK(prof["seconds"]["physics"].get<double>() > 0);
  CHECK(prof["slot_steps_per_s"].get<double>() > 0);
  // the rollout's acting and storing, and the update's stages (rl/stage_timer.h): each at least
  // 0, all within the update's time; one host read per update (its statistics and learning
  // rate), none inside the epochs: 2 updates x 1 = 2
  CHECK(prof["seconds"]["act"].get<double>() > 0);
  CHECK(prof["seconds"]["store"].get<double>() >= 0);
  CHECK(prof["seconds"]["act"].get<double>() + prof["seconds"]["store"].get<double>() <=
        prof["seconds"]["policy"].get<double>() + prof["seconds"]["simulation"].get<double>());
  REQUIRE(prof.contains("learner"));
  double stages = 0;
  for (const char* k : {"gae", "prepare", "forward", "kl_check", "backward", "clip_grad",
                        "optimizer", "stats", "read_stats"}) {
    INFO(k);
    CHECK(prof["learner"][k].get<double>() >= 0);
    stages += prof["learner"][k].get<double>();
  }
  CHECK(prof["learner"]["forward"].get<double>() > 0);
  CHECK(stages <= prof["seconds"]["update"].get<double>());
  CHECK(prof["learner"]["host_syncs"].get<double>() == 2);

  // the run goes on from its checkpoint with the simulation on the CPU
  rl::TrainOptions back = test::quiet();
  back.device = "cpu";
  const rl::TrainResult r2 = rl::train_resume(dir, back);
  CHECK(r2.updates == 3);
  CHECK(r2.sim_device == "cpu");
  const auto run2 = nlohmann::json::parse(read_file(dir + "/run.json"));
  REQUIRE(run2["sessions"].size() == 2);
  CHECK(run2["sessions"][1]["sim_device"] == "cpu");
  CHECK(run2["sessions"][1]["from_update"] == 2);
}

TEST_CASE("without a GPU, a GPU pack or run is a clear error naming what is missing",
          "[warp][rl][train]") {
  if (sim::cuda::driver_available()) {
    WARN("an NVIDIA driver is present: nothing to check here");
    return;
  }
  taskpack::WarpPackOptions o;
  o.device = "cuda";
  try {
    taskpack::WarpPack pack(two_tasks(), o);
    FAIL("a GPU pack without a GPU");
  } catch (const DeviceError& e) {
    CHECK_THAT(e.what(), Catch::Contains("NVIDIA driver") && Catch::Contains("--device cpu"));
  }
  // auto: the CPU, with the reason
  std::string why;
  CHECK(taskpack::choose_pack_device("auto", two_tasks(), &why) == "cpu");
  CHECK_THAT(why, Catch::Contains("driver") || Catch::Contains("GPU backend"));
  // through the trainer: the learner's LibTorch has no CUDA here either
  test::TaskTempDir tmp;
  rl::TrainOptions t = test::quiet();
  t.device = "cuda";
  const std::string yaml =
      test::tiny_yaml("catch_underarm_raise", {"train.steps=32", "train.device=auto"});
  CHECK_THROWS_AS(rl::train_new(yaml, tmp.file("run"), t), Error);
}

TEST_CASE("multi-task PPO trains on a suite packed on the GPU path's code", "[warp][rl][train]") {
  // MT4 on Warp's CPU device: four scenes, one slot each, per-task metric columns
  test::TaskTempDir tmp;
  const std::string dir = tmp.file("run");
  const std::string yaml = test::tiny_onpolicy_yaml("mtppo", "MT4", {"train.steps=32"});
  rl::TrainOptions o = test::quiet();
  o.device = "warp-cpu";
  const rl::TrainResult r = rl::train_new(yaml, dir, o);
  CHECK(r.updates == 1);
  CHECK(r.sim_device == "warp-cpu");
  REQUIRE(r.scores.size() == 4);
  CHECK(r.scores[1].label == "hand_over");
  const std::string csv = read_file(dir + "/metrics.csv");
  for (const char* col : {"scaled_return", "return_catch_underarm", "success_two_catch_underarm"})
    CHECK(csv.find(col) != std::string::npos);
}

TEST_CASE("a pack shares a backend among scenes of one topology and writes the rows of one "
          "backend per scene", "[warp][taskpack]") {
  // three catch scenes and two door scenes differ only in fields MuJoCo Warp takes per world
  // (hand poses, joint axes, initial positions); push_block stands alone
  taskpack::PackSpec spec;
  spec.name = "topology";
  spec.mode = taskpack::PackMode::kMultiTask;
  const std::vector<std::pair<std::string, int>> entries = {
      {"catch_underarm", 2}, {"push_block", 1},         {"door_open_inward", 2},
      {"catch_abreast", 2},  {"door_close_outward", 1}, {"catch_over2underarm", 1}};
  for (const auto& [task, slots] : entries) {
    taskpack::PackEntry e;
    e.task = task;
    e.slots = slots;
    e.reward_scale = 1.0 + 0.5 * static_cast<double>(spec.entries.size());
    spec.entries.push_back(e);
  }
  taskpack::WarpPackOptions o = on_warp_cpu(23);
  taskpack::WarpPack shared(spec, o);
  o.share_scenes = false;
  taskpack::WarpPack separate(spec, o);

  // the groups: catch entries 0, 3, 5 on one backend in that order, doors 2 and 4, push_block
  // alone; separately, every entry alone
  auto tasks_of = [&](int g) {
    std::vector<std::string> out;
    for (const tasks::WarpTaskEnv* e : shared.group(g).group()) out.push_back(e->spec().id);
    return out;
  };
  CHECK(tasks_of(3) == std::vector<std::string>{"catch_underarm", "catch_abreast",
                                                "catch_over2underarm"});
  CHECK(tasks_of(2) == std::vector<std::string>{"door_open_inward", "door_close_outward"});
  CHECK(tasks_of(1) == std::vector<std::string>{"push_block"});
  CHECK(&shared.group(0).backend() == &shared.group(5).backend());
  CHECK(shared.group(0).backend().nworld() == 5);
  CHECK(shared.group(5).first_world() == 4);
  for (int g = 0; g < separate.ngroups(); ++g) CHECK(separate.group(g).group().size() == 1);

  // Rows of `slots` (all when empty): bit for bit (tolerance 0), or within `tol`.
  auto same = [&](const std::string& what, double tol, std::vector<int> slots = {}) {
    if (slots.empty())
      for (int s = 0; s < shared.nslot(); ++s) slots.push_back(s);
    for (const char* name : {"obs", "reward", "done", "bootstrap"}) {
      const std::vector<float> a = shared.download(name), b = separate.download(name);
      REQUIRE(a.size() == b.size());
      const size_t width = a.size() / size_t(shared.nslot());
      double diff = 0;
      int bad = 0;
      for (int s : slots)
        for (size_t k = s * width; k < (s + 1) * width; ++k) {
          bad += !std::isfinite(a[k]);
          diff = std::max(diff, std::abs(double(a[k]) - double(b[k])));
        }
      INFO(what << ": " << name << " differs by up to " << diff);
      CHECK(bad == 0);
      CHECK(diff <= tol);
    }
  };
  // each world starts from its own scene's state, whatever backend holds it
  same("after construction", 0);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  std::vector<float> act(size_t(shared.nslot()) * shared.act_dim());
  // MuJoCo Warp's contact step depends on a backend's world count in the last float32 bits, for
  // one scene as for several: on Warp's CPU device catch_underarm's world 1 differs by 1.2e-6 in
  // its observation after one step at 3 worlds against 2, and chaotic contacts grow such bits.
  // So the steps agree within float32 rounding for a few steps, not bit for bit.
  for (int t = 0; t < 3; ++t) {
    for (float& x : act) x = u(rng);
    shared.step(act);
    separate.step(act);
    same("step " + std::to_string(t), 1e-4);
  }
  // new episodes in some slots of both groups and of the lone entry: the same reset draws,
  // bit for bit (a reset world's rows come from the task's reset and the position pass)
  std::vector<uint8_t> mask(size_t(shared.nslot()), 0);
  for (int s : {0, 2, 4, 7}) mask[s] = 1;
  shared.reset_slots(mask.data());
  separate.reset_slots(mask.data());
  same("after reset_slots", 0, {0, 2, 4, 7});
  same("after reset_slots", 1e-4);
  const auto sa = shared.take_stats(), sb = separate.take_stats();
  REQUIRE(sa.size() == sb.size());
  CHECK(shared.total_faults() == 0);
  CHECK(separate.total_faults() == 0);
  CHECK(shared.room_advice().empty());
  const auto ra = shared.rows();
  REQUIRE(ra.size() == 6);
  for (const auto& r : ra) CHECK(r.needed <= r.room);
}
