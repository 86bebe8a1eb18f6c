// offline through the bidex binary, as a user runs it: collect (reproducible checksums, merge,
// its errors), train --record-replay, train --dataset with the registry, dataset verify, and the
// errors of train with datasets; and the config checks of dataset runs (rl::parse_train_config).
#include "tests/rl/rl_fixture.h"

#include <fstream>

#include <dirent.h>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "offline/algorithms.h"
#include "registry/registry.h"

using namespace bidex;
using test::bidex_run;
using test::CommandResult;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

nlohmann::json metadata(const std::string& dir) {
  return nlohmann::json::parse(read_file(dir + "/data/metadata.json"));
}

// A random dataset of catch_underarm_raise: 500 steps of 8 slots, few reference episodes.
CommandResult collect_random(const std::string& out, const std::string& extra = "") {
  return bidex_run("collect --task catch_underarm_raise --quality random --steps 500 --slots 8 "
                   "--device cpu --ref-episodes 8 --threads 1 --no-registry --out " + q(out) +
                   " " + extra);
}

// The entries of a folder other than . and ..; 0 when it does not exist.
int entries(const std::string& dir) {
  DIR* d = ::opendir(dir.c_str());
  if (!d) return 0;
  int n = 0;
  while (const dirent* e = ::readdir(d))
    if (std::string(e->d_name) != "." && std::string(e->d_name) != "..") ++n;
  ::closedir(d);
  return n;
}

}  // namespace

TEST_CASE("bidex collect writes the same dataset twice from the same seed",
          "[offline][cmd]") {
  test::TaskTempDir tmp;
  for (const char* d : {"a", "b"}) {
    const CommandResult r = collect_random(tmp.file(d), "--seed 3");
    INFO(r.out);
    REQUIRE(r.rc == 0);
  }
  const auto a = metadata(tmp.file("a")), b = metadata(tmp.file("b"));
  CHECK(a["checksum"].get<std::string>().rfind("sha256:", 0) == 0);
  CHECK(a["checksum"] == b["checksum"]);
  CHECK(a["total_steps"].get<int64_t>() >= 500);
  CHECK(a["quality"] == "random");
  const CommandResult c = collect_random(tmp.file("c"), "--seed 4");
  REQUIRE(c.rc == 0);
  CHECK(metadata(tmp.file("c"))["checksum"] != a["checksum"]);
}

TEST_CASE("bidex train --record-replay, collect from the run and train --dataset with a registry",
          "[offline][cmd]") {
  test::TaskTempDir tmp;
  const std::string run = tmp.file("ppo"), replay = tmp.file("replay-v0");
  // one checkpoint only (save_interval beyond the run): a medium policy cannot be chosen
  CommandResult r = bidex_run("train --task catch_underarm_raise -o env.slots=8 -o "
                              "train.steps=2000 -o train.save_interval=1000 -o env.threads=1 "
                              "--record-replay " + q(replay) + " --replay-steps 300 "
                              "--no-registry --run " + q(run));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  r = bidex_run("dataset verify " + q(replay));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  const auto rm = metadata(replay);
  CHECK(rm["quality"] == "replay");
  CHECK(rm["total_steps"].get<int64_t>() >= 300);

  r = bidex_run("collect --quality medium --run " + q(run) + " --steps 100 --slots 4 "
                "--device cpu --ref-episodes 4 --no-registry --out " + q(tmp.file("medium")));
  CHECK(r.rc == 2);
  CHECK_THAT(r.out, Catch::Contains("checkpoint"));
  CHECK(entries(tmp.file("medium")) == 0);

  // random with the run as expert (both references), an expert dataset, and their merge
  const std::string rnd = tmp.file("random-v0"), exp = tmp.file("expert-v0");
  r = collect_random(rnd, "--expert " + q(run));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  r = bidex_run("collect --quality expert --run " + q(run) + " --steps 200 --slots 8 "
                "--device cpu --ref-episodes 8 --threads 1 --no-registry --out " + q(exp));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  const std::string mix = tmp.file("mixed-v0");
  r = bidex_run("collect --quality medium-expert --merge " + q(rnd) + " " + q(exp) +
                " --no-registry --out " + q(mix));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  const auto mm = metadata(mix);
  CHECK(mm["quality"] == "medium-expert");
  REQUIRE(mm["sources"].size() == 2);
  CHECK(mm["sources"][0].get<std::string>().find(metadata(rnd)["checksum"].get<std::string>()) !=
        std::string::npos);
  CHECK(mm["sources"][1].get<std::string>().find(metadata(exp)["checksum"].get<std::string>()) !=
        std::string::npos);
  CHECK(mm["total_steps"] == metadata(rnd)["total_steps"].get<int64_t>() +
                                 metadata(exp)["total_steps"].get<int64_t>());
  r = bidex_run("dataset verify " + q(mix));
  CHECK(r.rc == 0);

  const std::string reg = tmp.file("registry.sqlite"), td3bc = tmp.file("td3bc");
  r = bidex_run("train --algo td3bc --dataset " + q(rnd) + " -o env.slots=4 -o env.threads=1 "
                "-o td3bc.gradient_steps=20 -o train.steps=40 --registry " + q(reg) +
                " --run " + q(td3bc));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK_THAT(r.out, Catch::Contains("40 gradient steps"));
  CHECK_THAT(r.out, Catch::Contains("normalised score"));
  CHECK_THAT(r.out, !Catch::Contains("normalised score n/a"));  // the dataset has both
  registry::Registry db(reg);
  const auto runs = db.runs();
  REQUIRE(runs.size() == 1);
  CHECK(runs[0].algo == "td3bc");
  CHECK(runs[0].task == "catch_underarm_raise");
  CHECK(runs[0].status == "finished");
  CHECK(runs[0].dataset == metadata(rnd)["checksum"].get<std::string>());
  const auto ds = db.dataset(runs[0].dataset);
  REQUIRE(ds);
  CHECK(ds->quality == "random");
  CHECK(ds->total_steps == metadata(rnd)["total_steps"].get<int64_t>());
  REQUIRE(ds->ref_min);
  REQUIRE(ds->ref_max);
}

TEST_CASE("bidex train and collect refuse what does not fit a dataset", "[offline][cmd]") {
  test::TaskTempDir tmp;
  const std::string d = tmp.file("random-v0");
  CommandResult r = collect_random(d);
  INFO(r.out);
  REQUIRE(r.rc == 0);
  const std::string run = " --no-registry --run " + q(tmp.file("run"));

  r = bidex_run("train --algo td3bc --task catch_underarm_raise" + run);
  CHECK(r.rc == 2);
  CHECK_THAT(r.out, Catch::Contains("--dataset"));
  r = bidex_run("train --algo ppo --dataset " + q(d) + run);
  CHECK(r.rc == 2);
  CHECK_THAT(r.out, Catch::Contains("--dataset"));
  r = bidex_run("train --algo bc --task hand_over --dataset " + q(d) + run);
  CHECK(r.rc == 2);
  CHECK_THAT(r.out, Catch::Contains("hand_over"));
  CHECK_THAT(r.out, Catch::Contains("catch_underarm_raise"));
  r = bidex_run("train --task catch_underarm_raise --resume " + q(tmp.file("x")) +
                " --record-replay " + q(tmp.file("replay")));
  CHECK(r.rc == 2);
  r = bidex_run("train --resume " + q(tmp.file("x")) + " --record-replay " +
                q(tmp.file("replay")));
  CHECK(r.rc == 2);
  CHECK_THAT(r.out, Catch::Contains("--record-replay"));
  CHECK(entries(tmp.file("run")) == 0);
  // a taken replay destination stops the run before its folder is made
  r = bidex_run("train --task catch_underarm_raise -o env.slots=4 -o train.steps=64 "
                "--record-replay " + q(d) + run);
  CHECK(r.rc == 2);
  CHECK_THAT(r.out, Catch::Contains("not an empty folder"));
  CHECK(entries(tmp.file("run")) == 0);

  // a corrupted main_data.hdf5: its bytes changed (the structure still reads; only the
  // checksum, checked when training prepares) and then cut in half
  const std::string h5 = d + "/data/main_data.hdf5";
  std::string bytes = read_file(h5);
  bytes[bytes.size() - 100] = static_cast<char>(bytes[bytes.size() - 100] ^ 0x55);
  std::ofstream(h5, std::ios::binary | std::ios::trunc) << bytes;
  r = bidex_run("train --algo bc --dataset " + q(d) + run);
  CHECK(r.rc == 2);
  CHECK_THAT(r.out, Catch::Contains("main_data.hdf5"));
  CHECK(entries(tmp.file("run")) == 0);
  std::ofstream(h5, std::ios::binary | std::ios::trunc) << bytes.substr(0, bytes.size() / 2);
  r = bidex_run("train --algo bc --dataset " + q(d) + run);
  CHECK(r.rc == 2);
  CHECK_THAT(r.out, Catch::Contains("main_data.hdf5"));
  CHECK(entries(tmp.file("run")) == 0);
  r = bidex_run("dataset verify " + q(d));
  CHECK(r.rc == 2);
}

TEST_CASE("a dataset run's config has a dataset and only a dataset run has one",
          "[offline][config]") {
  offline::register_algorithms();
  // resolve_train_yaml refuses an offline algorithm without a dataset, so write the key out
  std::string yaml = rl::resolve_train_yaml(rl::default_train_config("td3bc"), "td3bc",
                                            "catch_underarm_raise", {}, "/data/x-v0");
  CHECK(rl::parse_train_config(yaml, "td3bc").dataset == "/data/x-v0");
  const size_t at = yaml.find("dataset:");
  REQUIRE(at != std::string::npos);
  const std::string without = yaml.substr(0, at) + yaml.substr(yaml.find('\n', at) + 1);
  CHECK_THROWS_WITH(rl::parse_train_config(without, "td3bc"), Catch::Contains("dataset"));
  CHECK_THROWS_AS(rl::parse_train_config(without, "td3bc"), ConfigError);

  const std::string ppo = rl::resolve_train_yaml(rl::default_train_config("ppo"), "ppo",
                                                 "catch_underarm_raise", {});
  CHECK_THROWS_AS(rl::parse_train_config(ppo + "dataset: /data/x-v0\n", "ppo"), ConfigError);
  CHECK_THROWS_WITH(rl::parse_train_config(ppo + "dataset: /data/x-v0\n", "ppo"),
                    Catch::Contains("dataset"));
}
