// bidex_gpu_engine: the GPU engine's checks and measurements on a CUDA machine.
//   bidex_gpu_engine parity  every stage against MuJoCo 2.2.2 on the GPU (both precisions, every
//                            lane width), one step, a 1 s trajectory; JSON report; exit 1 on a
//                            failure
//   bidex_gpu_engine bench   world-steps/s of the contact-free two-hand scene per precision,
//                            lanes per world and world count, memory per world, stage times
// Both build the reference two-hand scene from configs/ (as `bidex sim` does) with contacts
// disabled; `--engine host` runs the parity checks on the host engine instead (no GPU needed).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

#include "bench/sim_bench.h"
#include "core/error.h"
#include "sim/gpu/device_engine.h"
#include "sim/gpu/engine.h"
#include "sim/gpu/parity.h"
#include "sim/hand_spec.h"
#include "sim/model.h"
#include "sim/physics.h"
#include "sim/scene.h"

using json = nlohmann::json;
using namespace bidex;
using namespace bidex::sim::gpu;

namespace {

// the reference scene, its gravity compensation, and a contact-free copy with the engine tables
struct Scene {
  explicit Scene(const std::string& hand_path)
      : model(sim::two_hand_scene(sim::load_hand_spec(hand_path),
                                  sim::load_physics(sim::default_physics_path()))
                  .build("two_hand_scene")),
        m(contact_free_copy(model.mj())),
        arrays(m) {}
  ~Scene() { mj_deleteModel(m); }
  sim::SimModel model;
  mjModel* m;
  ModelArrays arrays;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  size_t at = 0;
  while (at <= s.size()) {
    size_t next = s.find(',', at);
    if (next == std::string::npos) next = s.size();
    if (next > at) out.push_back(s.substr(at, next - at));
    at = next + 1;
  }
  return out;
}

std::vector<int> split_ints(const std::string& s) {
  std::vector<int> out;
  for (const std::string& x : split(s)) out.push_back(std::stoi(x));
  return out;
}

bool is_f32(const std::string& p) {
  if (p == "f32" || p == "float32") return true;
  if (p == "f64" || p == "float64") return false;
  throw ConfigError("", "--precision", "f32 or f64", p);
}

json report_json(const ParityReport& r) {
  json j;
  j["engine"] = r.engine;
  j["check"] = r.check;
  j["pass"] = r.pass();
  j["seconds"] = r.seconds;
  j["fields"] = json::array();
  for (const FieldCheck& f : r.fields) {
    json x;
    x["stage"] = f.stage;
    x["field"] = f.field;
    x["count"] = f.count;
    x["pass"] = f.pass();
    if (f.exact) {
      x["exact"] = true;
    } else {
      x["atol"] = f.tol.atol;
      x["rtol"] = f.tol.rtol;
      x["of_max"] = f.tol.of_max;
    }
    x["max_abs_error"] = std::isfinite(f.max_abs) ? json(f.max_abs) : json("inf");
    x["max_ratio_to_tolerance"] = std::isfinite(f.max_ratio) ? json(f.max_ratio) : json("inf");
    x["mismatched"] = f.mismatched;
    if (!f.pass()) x["worst"] = f.worst;
    j["fields"].push_back(x);
  }
  return j;
}

void write_json(const json& j, const std::string& path) {
  if (path.empty()) return;
  std::ofstream f(path);
  if (!f) throw IoError(path + ": cannot write");
  f << j.dump(2) << "\n";
  std::printf("wrote %s\n", path.c_str());
}

std::unique_ptr<Engine> make_engine(const std::string& where, const ModelArrays& a, int nworld,
                                    bool f32, int lanes) {
  if (where == "host") {
    if (f32) return std::make_unique<HostEngine<float>>(a, nworld);
    return std::make_unique<HostEngine<double>>(a, nworld);
  }
  if (where == "cuda") return make_device_engine(a, nworld, f32, lanes);
  throw ConfigError("", "--engine", "cuda or host", where);
}

struct ParityOptions {
  std::string engine = "cuda";
  std::string precision = "f64,f32";
  std::string lanes = "4,8,16,32";
  int worlds = 256;
  int trajectory_worlds = 16;
  double seconds = 1.0;
  uint64_t seed = 100;
  std::string out;
  std::string hand;
};

int run_parity(const ParityOptions& o) {
  Scene scene(o.hand.empty() ? sim::default_hand_path() : o.hand);
  mjModel* fm = sim::compile_mjcf(features_mjcf(), "gpu_features");
  ModelArrays farrays(fm);
  json out;
  out["machine"] = bench::machine_info();
  out["device"] = cuda_device_description();
  out["scene"] = {{"name", "two_hand_scene, contacts disabled"}, {"nq", scene.m->nq},
                  {"nv", scene.m->nv}, {"nu", scene.m->nu}, {"nbody", scene.m->nbody},
                  {"constraint_candidates", scene.arrays.s.ncand}};
  out["reports"] = json::array();
  bool all = true;
  auto keep = [&](const std::string& model, const ParityReport& r) {
    std::cout << model << ": " << r.table() << std::flush;
    if (!r.pass()) std::cout << r.failures();
    json j = report_json(r);
    j["model"] = model;
    out["reports"].push_back(j);
    all = all && r.pass();
  };
  const std::vector<int> lanes = o.engine == "host" ? std::vector<int>{1} : split_ints(o.lanes);
  uint64_t seed = o.seed;
  for (const std::string& p : split(o.precision)) {
    const bool f32 = is_f32(p);
    for (int L : lanes) {
      // every stage kernel and the fused step kernel, at random states in many worlds
      auto e = make_engine(o.engine, scene.arrays, o.worlds, f32, L);
      keep("two_hand_scene", check_forward(scene.m, scene.arrays, *e, ++seed, f32));
      keep("two_hand_scene", check_step(scene.m, scene.arrays, *e, ++seed, f32));
      auto ef = make_engine(o.engine, farrays, 32, f32, L);
      keep("features", check_forward(fm, farrays, *ef, ++seed, f32));
      keep("features", check_step(fm, farrays, *ef, ++seed, f32));
    }
    // the trajectory under random position targets, with the hands' gravity compensation
    auto e = make_engine(o.engine, scene.arrays, o.trajectory_worlds, f32, lanes.front());
    keep("two_hand_scene",
         check_trajectory(scene.m, scene.arrays, *e, ++seed, f32, o.seconds,
                          scene.model.physics().substeps, scene.model.gravity_compensation()));
  }
  mj_deleteModel(fm);
  out["pass"] = all;
  write_json(out, o.out);
  std::printf("parity: %s\n", all ? "PASS" : "FAIL");
  return all ? 0 : 1;
}

struct BenchOptions {
  std::string precision = "f32,f64";
  std::string lanes = "4,8,16,32";
  std::string caps = "0,1,2,4,8";  // resident blocks per SM (0: no cap)
  std::string worlds = "1024,4096,16384,65536";
  int sweep_worlds = 16384;   // lane widths are compared at this world count
  double min_seconds = 1.0;   // of timed stepping per measurement
  int rounds = 2;             // measurements per configuration; the best is kept
  bool observe = true;
  std::string out;
  std::string hand;
};

// world-steps/s of one configuration (best of `rounds`), with its details
json bench_one(const Scene& scene, bool f32, int lanes, int blocks_per_sm, int nworld,
               const BenchOptions& o) {
  json r;
  r["precision"] = f32 ? "float32" : "float64";
  r["lanes"] = lanes;
  r["resident_blocks_per_sm"] = blocks_per_sm;
  r["worlds"] = nworld;
  try {
    auto e = make_device_engine(scene.arrays, nworld, f32, lanes);
    e->set_resident_blocks_per_sm(blocks_per_sm);
    const int substeps = scene.model.physics().substeps;
    e->reset_worlds(scene.model.gravity_compensation(), 7);
    // warm up, then enough launches for min_seconds
    const double t1 = e->time_steps(2, substeps, o.observe, 1000) / 2;
    const int launches =
        std::clamp(static_cast<int>(std::ceil(o.min_seconds / std::max(t1, 1e-6))), 3, 200);
    double best = 1e300;
    for (int k = 0; k < o.rounds; ++k)
      best = std::min(best,
                      e->time_steps(launches, substeps, o.observe, 2000 + 1000 * k) / launches);
    const double steps_per_s = static_cast<double>(nworld) * substeps / best;
    r["substeps_per_launch"] = substeps;
    r["launches"] = launches;
    r["seconds_per_control_step"] = best;
    r["world_steps_per_s"] = steps_per_s;
    r["control_steps_per_s"] = nworld / best;
    r["state_bytes_per_world"] = static_cast<double>(e->state_bytes()) / nworld;
    r["model_bytes"] = e->model_bytes();
    r["mean_solver_iterations"] = e->mean_solver_iterations();
    r["faulty_worlds"] = e->faulty_worlds();
    std::printf("  %s lanes %2d blocks/SM %d worlds %6d: %10.0f world-steps/s  (%.3f ms per "
                "control step of %d substeps, %.1f KB per world, %.2f solver iterations, %d "
                "faulty)\n",
                f32 ? "f32" : "f64", lanes, blocks_per_sm, nworld, steps_per_s, best * 1e3,
                substeps, e->state_bytes() / 1024.0 / nworld,
                r["mean_solver_iterations"].get<double>(), r["faulty_worlds"].get<int>());
  } catch (const std::exception& ex) {
    r["error"] = ex.what();
    std::printf("  %s lanes %2d blocks/SM %d worlds %6d: %s\n", f32 ? "f32" : "f64", lanes,
                blocks_per_sm, nworld, ex.what());
  }
  std::fflush(stdout);
  return r;
}

int run_bench(const BenchOptions& o) {
  Scene scene(o.hand.empty() ? sim::default_hand_path() : o.hand);
  if (cuda_device_count() == 0) throw std::runtime_error(cuda_device_description());
  json out;
  out["machine"] = bench::machine_info();
  out["device"] = cuda_device_description();
  out["scene"] = {{"name", "two_hand_scene, contacts disabled"}, {"nq", scene.m->nq},
                  {"nv", scene.m->nv}, {"nu", scene.m->nu}, {"nbody", scene.m->nbody},
                  {"timestep", scene.m->opt.timestep},
                  {"substeps", scene.model.physics().substeps},
                  {"solver_iterations_cap", scene.m->opt.iterations},
                  {"constraint_candidates", scene.arrays.s.ncand}};
  out["inputs"] = "every world from the reference pose at rest, gravity compensation of the "
                  "hands as applied forces, new uniform random position targets every control "
                  "step";
  out["observe"] = o.observe;
  out["lane_sweep"] = json::array();
  out["runs"] = json::array();
  out["stages"] = json::object();
  std::printf("%s\n", cuda_device_description().c_str());
  for (const std::string& p : split(o.precision)) {
    const bool f32 = is_f32(p);
    auto rate = [](const json& r) {
      return r.contains("world_steps_per_s") ? r["world_steps_per_s"].get<double>() : 0.0;
    };
    // lanes per world, then the grid cap: the fastest at the sweep size
    std::printf("%s: lanes per world at %d worlds:\n", p.c_str(), o.sweep_worlds);
    int lanes = 0, cap = 0;
    double best = 0;
    for (int L : split_ints(o.lanes)) {
      json r = bench_one(scene, f32, L, 0, o.sweep_worlds, o);
      out["lane_sweep"].push_back(r);
      if (rate(r) > best) {
        best = rate(r);
        lanes = L;
      }
    }
    if (lanes == 0) continue;
    std::printf("%s: resident blocks per SM at %d lanes:\n", p.c_str(), lanes);
    for (int c : split_ints(o.caps)) {
      if (c == 0) continue;  // measured in the lane sweep
      json r = bench_one(scene, f32, lanes, c, o.sweep_worlds, o);
      out["lane_sweep"].push_back(r);
      if (rate(r) > best) {
        best = rate(r);
        cap = c;
      }
    }
    std::printf("%s: worlds at %d lanes, %d blocks per SM:\n", p.c_str(), lanes, cap);
    for (int n : split_ints(o.worlds))
      out["runs"].push_back(bench_one(scene, f32, lanes, cap, n, o));
    // time per stage, ns per world-step, at the sweep size
    auto e = make_device_engine(scene.arrays, o.sweep_worlds, f32, lanes);
    e->set_resident_blocks_per_sm(cap);
    e->reset_worlds(scene.model.gravity_compensation(), 7);
    e->time_steps(3, scene.model.physics().substeps, false, 1);
    json st = json::array();
    double total = 0;
    for (const auto& [name, sec] : e->time_stages(5)) {
      const double ns = sec * 1e9 / o.sweep_worlds;
      total += ns;
      st.push_back({{"stage", name}, {"ns_per_world", ns}});
      std::printf("  stage %-18s %8.1f ns per world\n", name.c_str(), ns);
    }
    out["stages"][f32 ? "float32" : "float64"] = {
        {"lanes", lanes}, {"resident_blocks_per_sm", cap}, {"worlds", o.sweep_worlds},
        {"stages", st}, {"sum_ns_per_world", total}};
  }
  write_json(out, o.out);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"bidex_gpu_engine: parity checks and benchmark of the GPU engine"};
  app.require_subcommand(1);

  ParityOptions po;
  CLI::App* parity =
      app.add_subcommand("parity", "every stage against MuJoCo 2.2.2 (exit 1 on a failure)");
  parity->add_option("--engine", po.engine, "cuda or host")->capture_default_str();
  parity->add_option("--precision", po.precision, "f64, f32 or both")->capture_default_str();
  parity->add_option("--lanes", po.lanes, "lanes per world to check (cuda)")->capture_default_str();
  parity->add_option("--worlds", po.worlds, "worlds of the stage checks")->capture_default_str();
  parity->add_option("--trajectory-worlds", po.trajectory_worlds, "worlds of the trajectory check")
      ->capture_default_str();
  parity->add_option("--seconds", po.seconds, "simulated seconds of the trajectory check")
      ->capture_default_str();
  parity->add_option("--seed", po.seed, "seed of the random states")->capture_default_str();
  parity->add_option("--out", po.out, "JSON report");
  parity->add_option("--hand", po.hand, "hand spec (default: configs/hands/shadow.yaml)");

  BenchOptions bo;
  CLI::App* bench = app.add_subcommand("bench", "world-steps/s, memory per world, stage times");
  bench->add_option("--precision", bo.precision, "f32, f64 or both")->capture_default_str();
  bench->add_option("--lanes", bo.lanes, "lanes per world to compare")->capture_default_str();
  bench->add_option("--caps", bo.caps, "resident blocks per SM to compare (0: no cap)")
      ->capture_default_str();
  bench->add_option("--worlds", bo.worlds, "world counts")->capture_default_str();
  bench->add_option("--sweep-worlds", bo.sweep_worlds, "world count of the lane comparison and "
                    "the stage times")->capture_default_str();
  bench->add_option("--seconds", bo.min_seconds, "timed seconds per measurement")
      ->capture_default_str();
  bench->add_option("--rounds", bo.rounds, "measurements per configuration (best kept)")
      ->capture_default_str();
  bench->add_option("--observe", bo.observe, "end each control step with a position and "
                    "velocity pass (poses for observations)")->capture_default_str();
  bench->add_option("--out", bo.out, "JSON results");
  bench->add_option("--hand", bo.hand, "hand spec (default: configs/hands/shadow.yaml)");

  try {
    app.parse(argc, argv);
    if (parity->parsed()) return run_parity(po);
    if (bench->parsed()) return run_bench(bo);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const bidex::Error& e) {
    std::fprintf(stderr, "bidex_gpu_engine: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bidex_gpu_engine: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
