#include "bench/agree_bench.h"

#include <cmath>
#include <cstdio>
#include <random>

#include "core/progress.h"
#include "tasks/env.h"
#include "tasks/registry.h"
#include "tasks/warp_env.h"

namespace bidex::bench {

using nlohmann::json;

namespace {

// Per-episode records of one side.
struct Episodes {
  std::vector<double> ret, len, success;
  int64_t faults = 0;
};

// Mean and standard error of the mean.
std::pair<double, double> mean_se(const std::vector<double>& x) {
  const double n = static_cast<double>(x.size());
  if (n < 2) return {n ? x[0] : 0, 0};
  double m = 0, v = 0;
  for (double a : x) m += a;
  m /= n;
  for (double a : x) v += (a - m) * (a - m);
  return {m, std::sqrt(v / (n - 1) / n)};
}

// Adds the episodes that finished this step: per-slot running returns and lengths.
template <class Flags>
void record(int n, const float* reward, const Flags& term, const Flags& trunc, const Flags& succ,
            const Flags& fault, std::vector<double>& run_ret, std::vector<int>& run_len,
            Episodes& out) {
  for (int s = 0; s < n; ++s) {
    run_ret[s] += reward[s];
    run_len[s] += 1;
    if (term[s] || trunc[s]) {
      out.ret.push_back(run_ret[s]);
      out.len.push_back(run_len[s]);
      out.success.push_back(succ[s] ? 1.0 : 0.0);
      out.faults += fault[s] ? 1 : 0;
      run_ret[s] = 0;
      run_len[s] = 0;
    }
  }
}

json compare(const char* what, const std::vector<double>& cpu, const std::vector<double>& gpu,
             double slack) {
  auto [mc, sc] = mean_se(cpu);
  auto [mg, sg] = mean_se(gpu);
  const double se = std::sqrt(sc * sc + sg * sg);
  const double tol = 4 * se + slack;
  return {{"metric", what}, {"cpu_mean", mc}, {"cpu_se", sc}, {"gpu_mean", mg}, {"gpu_se", sg},
          {"difference", mg - mc}, {"tolerance", tol}, {"agree", std::abs(mg - mc) <= tol}};
}

}  // namespace

json run_agree_bench(const AgreeBenchConfig& cfg) {
  json results = json::array();
  Progress bar("bench agree", static_cast<int64_t>(cfg.tasks.size()) * 2, "runs");
  int64_t done = 0;
  for (const auto& id : cfg.tasks) {
    Episodes cpu, gpu;
    {
      tasks::EnvOptions o;
      o.nslot = cfg.slots;
      o.threads = cfg.threads;
      o.seed = cfg.seed;
      tasks::TaskEnv env(tasks::make_task(id, ""), o);
      std::mt19937_64 rng(cfg.seed);
      std::vector<float> a(static_cast<size_t>(cfg.slots) * env.act_dim());
      std::vector<double> run_ret(cfg.slots, 0.0);
      std::vector<int> run_len(cfg.slots, 0);
      while (static_cast<int>(cpu.ret.size()) < cfg.episodes) {
        tasks::random_actions(a, rng);
        env.step(a);
        record(cfg.slots, env.reward.data(), env.terminated, env.truncated, env.success,
               env.fault, run_ret, run_len, cpu);
      }
      bar.update(++done);
    }
    {
      tasks::WarpEnvOptions o;
      o.nslot = cfg.slots;
      o.seed = cfg.seed;
      o.device = cfg.device;
      tasks::WarpTaskEnv env(tasks::make_task(id, ""), o);
      std::vector<double> run_ret(cfg.slots, 0.0);
      std::vector<int> run_len(cfg.slots, 0);
      for (int64_t t = 0; static_cast<int>(gpu.ret.size()) < cfg.episodes; ++t) {
        env.backend().random_fill("actions", cfg.seed, t, -1.0f, 1.0f);
        env.step();
        const auto r = env.download<float>("reward");
        record(cfg.slots, r.data(), env.download<uint8_t>("terminated"),
               env.download<uint8_t>("truncated"), env.download<uint8_t>("success"),
               env.download<uint8_t>("faulted"), run_ret, run_len, gpu);
      }
      bar.update(++done);
    }
    json metrics = json::array();
    double mret = mean_se(cpu.ret).first, mlen = mean_se(cpu.len).first;
    metrics.push_back(compare("return", cpu.ret, gpu.ret, 0.02 * std::abs(mret)));
    metrics.push_back(compare("length", cpu.len, gpu.len, 0.02 * std::abs(mlen)));
    metrics.push_back(compare("success_rate", cpu.success, gpu.success, 0.01));
    bool all = true;
    for (auto& m : metrics) all = all && m["agree"].get<bool>();
    results.push_back({{"task", id},
                       {"cpu_episodes", cpu.ret.size()},
                       {"gpu_episodes", gpu.ret.size()},
                       {"cpu_faults", cpu.faults},
                       {"gpu_faults", gpu.faults},
                       {"metrics", metrics},
                       {"agree", all}});
    std::fprintf(stderr, "%s: return cpu %.3f gpu %.3f, length %.1f / %.1f, %s\n", id.c_str(),
                 metrics[0]["cpu_mean"].get<double>(), metrics[0]["gpu_mean"].get<double>(),
                 metrics[1]["cpu_mean"].get<double>(), metrics[1]["gpu_mean"].get<double>(),
                 all ? "agree" : "DIFFER");
  }
  bar.finish();
  return {{"benchmark", "agree"},
          {"what", "a uniformly random policy on the CPU path (float64) and the GPU path (float32) "
                   "of each task: per-episode return, length and success; agree when |gpu - cpu| "
                   "<= 4 standard errors of the difference + 2% of the CPU mean (return, length) "
                   "or + 0.01 (success rate)"},
          {"slots", cfg.slots},
          {"results", results}};
}

}  // namespace bidex::bench
