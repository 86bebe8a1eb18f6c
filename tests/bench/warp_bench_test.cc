// bidex bench warp on Warp's CPU device (the GPU path's code, no GPU): the fault-checked
// slot-steps reach --min-checked however few the timed rounds held, faults are reported by kind,
// and --phases splits a substep into its parts.
#include "bench/warp_bench.h"

#include <catch2/catch.hpp>

namespace bidex::bench {

TEST_CASE("bench warp checks at least --min-checked slot-steps and reports faults by kind",
          "[warp][bench]") {
  WarpBenchConfig c;
  c.tasks = {"catch_underarm_raise"};
  c.worlds = {2};
  c.device = "cpu";
  c.min_seconds = 0.01;
  c.rounds = 1;
  c.warmup_steps = 1;
  c.determinism_steps = 0;
  c.min_checked = 60;
  c.phase_steps = 1;
  c.progress = false;
  const auto out = run_warp_bench(c);
  REQUIRE(out["results"].size() == 1);
  const auto& r = out["results"][0];
  CHECK(r["checked_slot_steps"].get<int64_t>() >= 60);
  CHECK(r["task_checked_slot_steps"].get<int64_t>() >= 60);
  CHECK(r["faults"] == 0);
  CHECK(r["fault_kinds"].empty());
  CHECK(r["task_fault_kinds"].empty());
  for (const char* k : {"collision_share", "make_constraint_share", "solver_share"}) {
    INFO(k);
    CHECK(r[k].get<double>() > 0);
    CHECK(r[k].get<double>() < 1);
  }
  CHECK(r["phase_ms"].size() == 5);
}

}  // namespace bidex::bench
