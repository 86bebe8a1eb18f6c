// offline/dataset: real HDF5 datasets in temp folders: round trip, reproducible bytes, corruption
// and its messages, dropped episodes, merge, D4RL export, h5py reading them, and
// `bidex dataset` as the real binary.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <hdf5.h>
#include <nlohmann/json.hpp>

#include <catch2/catch.hpp>

#include "core/files.h"
#include "offline/dataset.h"
#include "tests/fixture.h"
#include "tests/run_command.h"

using namespace bidex;
using namespace bidex::test;
using offline::DatasetError;
using offline::DatasetInfo;

namespace {

struct Ep {
  int64_t t = 0;
  std::vector<float> obs, act, rew;
  std::vector<uint8_t> term, trunc;
};

// An episode of `t` steps with distinct values drawn from `seed`; `end` flags its last step:
// 't' terminated, 'x' truncated, '-' neither.
Ep episode(int64_t t, int64_t od, int64_t ad, unsigned seed, char end) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-3.f, 3.f);
  Ep e;
  e.t = t;
  for (int64_t i = 0; i < (t + 1) * od; ++i) e.obs.push_back(u(rng));
  for (int64_t i = 0; i < t * ad; ++i) e.act.push_back(u(rng) / 3.f);
  for (int64_t i = 0; i < t; ++i) e.rew.push_back(u(rng));
  e.term.assign(static_cast<size_t>(t), 0);
  e.trunc.assign(static_cast<size_t>(t), 0);
  if (end == 't') e.term.back() = 1;
  if (end == 'x') e.trunc.back() = 1;
  return e;
}

DatasetInfo info_for(int64_t od, int64_t ad, const std::string& task = "hand_over") {
  DatasetInfo i;
  i.dataset_id = task + "/expert-v0";
  i.task = task;
  i.task_version = task + "-v0";
  i.quality = "expert";
  i.obs_dim = od;
  i.act_dim = ad;
  i.max_episode_steps = 75;
  i.ref_min_score = -5.5;
  i.ref_max_score = NAN;
  i.policy = "runs/x/checkpoints/update_000010.ckpt";
  i.algorithm_name = "ppo";
  i.seed = 123456789012345ull;
  i.code_version = "abc123";
  i.command = "bidex collect hand_over --quality expert";
  return i;
}

DatasetInfo write(const std::string& dir, const DatasetInfo& info, const std::vector<Ep>& eps) {
  offline::DatasetWriter w(dir, info);
  for (auto& e : eps)
    REQUIRE(w.add_episode(e.obs.data(), e.act.data(), e.rew.data(), e.term.data(),
                          e.trunc.data(), e.t));
  return w.finish();
}

// The three episodes most tests use: terminated, truncated, neither.
std::vector<Ep> three(int64_t od, int64_t ad, unsigned seed = 1) {
  return {episode(5, od, ad, seed, 't'), episode(7, od, ad, seed + 1, 'x'),
          episode(3, od, ad, seed + 2, '-')};
}

// what() of the DatasetError `f` throws
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const DatasetError& e) {
    return e.what();
  }
  FAIL("expected a DatasetError, none was thrown");
  return {};
}

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

std::string q(const std::string& s) {
  std::string out = "'";
  out.append(s).append("'");
  return out;
}

// The transitions the episodes `eps` hold, checked against `tr` value by value.
void check_transitions(const offline::Transitions& tr, const std::vector<Ep>& eps, int64_t od,
                       int64_t ad) {
  size_t step = 0, row = 0;
  for (auto& e : eps) {
    for (int64_t i = 0; i < e.t; ++i, ++step) {
      INFO("transition " << step);
      REQUIRE(tr.obs_row[step] == static_cast<int64_t>(row) + i);
      const float* o = tr.observations.data() + tr.obs_row[step] * od;
      for (int64_t c = 0; c < od; ++c) {
        CHECK(o[c] == e.obs[static_cast<size_t>(i * od + c)]);
        CHECK(o[od + c] == e.obs[static_cast<size_t>((i + 1) * od + c)]);  // next observation
      }
      for (int64_t c = 0; c < ad; ++c)
        CHECK(tr.actions[step * ad + c] == e.act[static_cast<size_t>(i * ad + c)]);
      CHECK(tr.rewards[step] == e.rew[static_cast<size_t>(i)]);
      CHECK(tr.terminations[step] == e.term[static_cast<size_t>(i)]);
      CHECK(tr.truncations[step] == e.trunc[static_cast<size_t>(i)]);
    }
    row += static_cast<size_t>(e.t) + 1;
  }
  CHECK(step == tr.rewards.size());
  CHECK(tr.observations.size() == (step + eps.size()) * static_cast<size_t>(od));
}

// no "DIR.partial-*" left beside the datasets in `parent`
void check_no_partial(const TempDir& parent) {
  for (auto& name : parent.list()) {
    INFO("entry " << name);
    CHECK(!has(name, ".partial-"));
  }
}

// Changes one byte of the values of `values` (4 floats, found once) in the file `h5`: the
// structure stays intact, only the checksum can tell.
void flip_data_byte(const std::string& h5, const float* values) {
  std::string bytes = read_file(h5);
  const std::string needle(reinterpret_cast<const char*>(values), 4 * sizeof(float));
  const size_t at = bytes.find(needle);
  REQUIRE(at != std::string::npos);
  REQUIRE(bytes.find(needle, at + 1) == std::string::npos);
  bytes[at + 2] = static_cast<char>(bytes[at + 2] ^ 0x10);
  std::ofstream out(h5, std::ios::binary | std::ios::trunc);
  out << bytes;
}

// A whole 1- or 2-D array of an HDF5 file, read as `mem_type` (test side: the C API directly).
template <class T>
std::vector<T> h5_read(hid_t file, const char* name, hid_t mem_type, std::vector<hsize_t>& dims) {
  hid_t ds = H5Dopen2(file, name, H5P_DEFAULT);
  REQUIRE(ds >= 0);
  hid_t space = H5Dget_space(ds);
  dims.assign(static_cast<size_t>(H5Sget_simple_extent_ndims(space)), 0);
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  size_t n = 1;
  for (auto d : dims) n *= d;
  std::vector<T> out(n);
  REQUIRE(H5Dread(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) >= 0);
  H5Sclose(space);
  H5Dclose(ds);
  return out;
}

}  // namespace

TEST_CASE("dataset: episodes written, verified and read back exactly", "[dataset][offline]") {
  TempDir tmp;
  const std::string dir = tmp.file("hand_over-expert");
  const auto eps = three(4, 2);
  offline::DatasetWriter w(dir, info_for(4, 2));
  for (auto& e : eps)
    REQUIRE(w.add_episode(e.obs.data(), e.act.data(), e.rew.data(), e.term.data(),
                          e.trunc.data(), e.t));
  CHECK(w.steps() == 15);
  CHECK(w.episodes() == 3);
  CHECK(!fs::exists(dir));  // written beside it until finished
  const DatasetInfo done = w.finish();
  CHECK(done.total_steps == 15);
  CHECK(done.total_episodes == 3);
  CHECK(done.dropped_episodes == 0);
  REQUIRE(done.checksum.size() == 7 + 64);
  CHECK(done.checksum.rfind("sha256:", 0) == 0);
  CHECK(fs::is_regular_file(dir + "/data/main_data.hdf5"));
  CHECK(fs::is_regular_file(dir + "/data/metadata.json"));
  CHECK(tmp.list() == std::vector<std::string>{"hand_over-expert"});

  const DatasetInfo i = offline::verify(dir);
  const DatasetInfo want = info_for(4, 2);
  CHECK(i.dataset_id == want.dataset_id);
  CHECK(i.task == want.task);
  CHECK(i.task_version == want.task_version);
  CHECK(i.quality == want.quality);
  CHECK(i.obs_dim == 4);
  CHECK(i.act_dim == 2);
  CHECK(i.max_episode_steps == 75);
  CHECK(i.ref_min_score == -5.5);
  CHECK(std::isnan(i.ref_max_score));  // unknown: null in the JSON
  CHECK(i.policy == want.policy);
  CHECK(i.algorithm_name == "ppo");
  CHECK(i.seed == want.seed);
  CHECK(i.code_version == "abc123");
  CHECK(i.command == want.command);
  CHECK(i.sources.empty());
  CHECK(i.total_steps == 15);
  CHECK(i.total_episodes == 3);
  CHECK(i.checksum == done.checksum);

  // the folder, its data/ folder or the file
  CHECK(offline::dataset_dir(dir + "/") == dir);
  CHECK(offline::dataset_dir(dir + "/data") == dir);
  CHECK(offline::dataset_dir(dir + "/data/main_data.hdf5") == dir);
  CHECK(offline::read_info(dir + "/data/main_data.hdf5").checksum == done.checksum);

  const offline::Transitions tr = offline::load_transitions(dir + "/data");
  CHECK(tr.steps == 15);
  CHECK(tr.info.checksum == done.checksum);
  check_transitions(tr, eps, 4, 2);
  // the three endings as written: terminated, truncated, neither
  CHECK(tr.terminations[4] == 1);
  CHECK(tr.truncations[4] == 0);
  CHECK(tr.truncations[11] == 1);
  CHECK(tr.terminations[11] == 0);
  CHECK(tr.terminations[14] == 0);
  CHECK(tr.truncations[14] == 0);

  SECTION("an existing empty folder is a fine destination") {
    const std::string empty = tmp.file("empty");
    fs::create_directory(empty);
    write(empty, info_for(4, 2), eps);
    CHECK(offline::verify(empty).checksum == done.checksum);
  }
  SECTION("the quality names") {
    CHECK(offline::qualities() ==
          std::vector<std::string>{"random", "replay", "medium", "expert", "medium-expert"});
  }
}

TEST_CASE("dataset: the same episodes give the same bytes, and another value another checksum",
          "[dataset][offline]") {
  TempDir tmp;
  const auto eps = three(6, 3, 7);
  const DatasetInfo a = write(tmp.file("a"), info_for(6, 3), eps);
  // HDF5's object time stamps count seconds: a later second would show if they were on
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  const DatasetInfo b = write(tmp.file("b"), info_for(6, 3), eps);
  CHECK(a.checksum == b.checksum);
  CHECK(read_file(tmp.file("a/data/main_data.hdf5")) ==
        read_file(tmp.file("b/data/main_data.hdf5")));

  auto changed = eps;
  changed[1].act[3] += 0.25f;
  const DatasetInfo c = write(tmp.file("c"), info_for(6, 3), changed);
  CHECK(c.checksum != a.checksum);
}

TEST_CASE("dataset: corrupted, incomplete or misplaced datasets give errors naming the file",
          "[dataset][offline]") {
  TempDir tmp;
  const std::string dir = tmp.file("ds");
  const std::string h5 = dir + "/data/main_data.hdf5";
  const std::string meta = dir + "/data/metadata.json";
  const auto eps = three(8, 3, 11);
  const DatasetInfo info = write(dir, info_for(8, 3), eps);

  SECTION("truncated HDF5 file") {
    fs::resize_file(h5, fs::file_size(h5) / 2);
    for (auto f : {&offline::read_info, &offline::verify}) {
      const std::string msg = error_of([&] { f(dir); });
      INFO(msg);
      CHECK(has(msg, h5));
      CHECK(has(msg, "not a readable HDF5 file"));
    }
    CHECK(has(error_of([&] { offline::load_transitions(dir, false); }), h5));
  }
  SECTION("not an HDF5 file at all") {
    write_file_atomic(h5, "hello");
    const std::string msg = error_of([&] { offline::read_info(dir); });
    CHECK(has(msg, h5 + ": not a readable HDF5 file"));
  }
  SECTION("one byte of the data flipped: the checksum tells") {
    flip_data_byte(h5, eps[1].obs.data());
    CHECK_NOTHROW(offline::read_info(dir));  // the structure is intact
    const std::string msg = error_of([&] { offline::verify(dir); });
    INFO(msg);
    CHECK(has(msg, h5));
    CHECK(has(msg, "checksum mismatch"));
    CHECK(has(msg, "expected " + info.checksum));
    CHECK(has(msg, "got sha256:"));
    CHECK(has(error_of([&] { offline::load_transitions(dir); }), "checksum mismatch"));
    // without the check the changed value is what comes back
    CHECK(offline::load_transitions(dir, false).observations[6 * 8] != eps[1].obs[0]);
  }
  SECTION("metadata.json missing") {
    fs::remove(meta);
    const std::string msg = error_of([&] { offline::read_info(dir); });
    CHECK(has(msg, meta));
    CHECK(has(msg, "missing"));
  }
  SECTION("metadata.json not JSON") {
    write_file_atomic(meta, "{\"dataset_id\": ");
    const std::string msg = error_of([&] { offline::verify(dir); });
    CHECK(has(msg, meta + ": not valid JSON"));
  }
  SECTION("metadata.json without a key, or with values that do not fit the file") {
    auto j = nlohmann::json::parse(read_file(meta));
    SECTION("no obs_dim") {
      j.erase("obs_dim");
      write_file_atomic(meta, j.dump());
      CHECK(error_of([&] { offline::read_info(dir); }) == meta + ": lacks the key 'obs_dim'");
    }
    SECTION("obs_dim 9 where the file has 8") {
      j["obs_dim"] = 9;
      write_file_atomic(meta, j.dump());
      CHECK(error_of([&] { offline::read_info(dir); }) ==
            h5 + ": episode_0/observations: expected shape (6, 9), got (6, 8)");
    }
    SECTION("act_dim 2 where the file has 3") {
      j["act_dim"] = 2;
      write_file_atomic(meta, j.dump());
      CHECK(error_of([&] { offline::read_info(dir); }) ==
            h5 + ": episode_0/actions: expected shape (5, 2), got (5, 3)");
    }
    SECTION("a step total that does not match") {
      j["total_steps"] = 16;
      write_file_atomic(meta, j.dump());
      CHECK(error_of([&] { offline::read_info(dir); }) ==
            h5 + ": its episodes hold 15 steps, " + meta + " counts 16");
    }
    SECTION("an episode more than the file holds") {
      j["total_episodes"] = 4;
      write_file_atomic(meta, j.dump());
      CHECK(error_of([&] { offline::read_info(dir); }) ==
            h5 + ": holds 3 episode groups, " + meta + " counts 4");
    }
  }
  SECTION("a destination that exists and is not empty is left alone") {
    for (const std::string& target : {dir, tmp.file("other")}) {
      fs::create_directories(target);
      write_file_atomic(target + "/keep.txt", "mine");
      const auto before = read_file(h5);
      const std::string msg = error_of([&] { offline::DatasetWriter w(target, info_for(8, 3)); });
      CHECK(has(msg, target));
      CHECK(has(msg, "not an empty folder"));
      CHECK(read_file(target + "/keep.txt") == "mine");
      CHECK(read_file(h5) == before);
    }
    CHECK_NOTHROW(offline::verify(dir));
    check_no_partial(tmp);
  }
  SECTION("a writer dropped before finish() leaves nothing") {
    {
      offline::DatasetWriter w(tmp.file("unfinished"), info_for(8, 3));
      const Ep& e = eps[0];
      REQUIRE(w.add_episode(e.obs.data(), e.act.data(), e.rew.data(), e.term.data(),
                            e.trunc.data(), e.t));
      CHECK(tmp.list().size() == 2);  // ds and the temporary folder
    }
    CHECK(tmp.list() == std::vector<std::string>{"ds"});
  }
  SECTION("the writer refuses zero widths and episodes that end before their last step") {
    CHECK(has(error_of([&] { offline::DatasetWriter w(tmp.file("z"), info_for(0, 3)); }),
              "obs_dim and act_dim > 0"));
    offline::DatasetWriter w(tmp.file("early"), info_for(8, 3));
    Ep e = episode(4, 8, 3, 5, '-');
    e.term[1] = 1;
    CHECK(has(error_of([&] {
                w.add_episode(e.obs.data(), e.act.data(), e.rew.data(), e.term.data(),
                              e.trunc.data(), e.t);
              }),
              "only the last step may terminate or truncate"));
  }
}

TEST_CASE("dataset: episodes with non-finite values are dropped and counted",
          "[dataset][offline]") {
  TempDir tmp;
  const std::string dir = tmp.file("ds");
  auto eps = three(4, 2, 21);
  Ep nan_obs = episode(4, 4, 2, 30, 't');
  nan_obs.obs[9] = NAN;
  Ep inf_rew = episode(2, 4, 2, 31, '-');
  inf_rew.rew[1] = INFINITY;
  Ep inf_act = episode(2, 4, 2, 32, '-');
  inf_act.act[0] = -INFINITY;
  offline::DatasetWriter w(dir, info_for(4, 2));
  auto add = [&](const Ep& e) {
    return w.add_episode(e.obs.data(), e.act.data(), e.rew.data(), e.term.data(), e.trunc.data(),
                         e.t);
  };
  CHECK(add(eps[0]));
  CHECK(!add(nan_obs));
  CHECK(add(eps[1]));
  CHECK(!add(inf_rew));
  CHECK(!add(inf_act));
  CHECK(add(eps[2]));
  CHECK(w.episodes() == 3);
  CHECK(w.steps() == 15);
  const DatasetInfo done = w.finish();
  CHECK(done.dropped_episodes == 3);
  CHECK(done.total_episodes == 3);
  const DatasetInfo i = offline::verify(dir);
  CHECK(i.dropped_episodes == 3);
  check_transitions(offline::load_transitions(dir), eps, 4, 2);
}

TEST_CASE("dataset: merge keeps the inputs' episodes in order and lists them",
          "[dataset][offline]") {
  TempDir tmp;
  const auto a_eps = three(5, 2, 41);
  const std::vector<Ep> b_eps = {episode(6, 5, 2, 50, 'x'), episode(2, 5, 2, 51, 't')};
  DatasetInfo ia = info_for(5, 2);
  ia.dataset_id = "hand_over/medium-v0";
  ia.quality = "medium";
  const DatasetInfo a = write(tmp.file("medium"), ia, a_eps);
  const DatasetInfo b = write(tmp.file("expert"), info_for(5, 2), b_eps);

  DatasetInfo m;
  m.dataset_id = "hand_over/medium-expert-v0";
  m.quality = "medium-expert";
  m.ref_min_score = 1;
  m.ref_max_score = 2;
  m.command = "bidex collect --merge";
  const DatasetInfo done = offline::merge({tmp.file("medium"), tmp.file("expert")},
                                          tmp.file("medium-expert"), m);
  CHECK(done.total_steps == a.total_steps + b.total_steps);
  CHECK(done.total_episodes == 5);
  CHECK(done.task == "hand_over");
  CHECK(done.obs_dim == 5);
  CHECK(done.act_dim == 2);
  CHECK(done.max_episode_steps == 75);
  CHECK(done.sources == std::vector<std::string>{"hand_over/medium-v0 " + a.checksum,
                                                 "hand_over/expert-v0 " + b.checksum});
  const DatasetInfo i = offline::verify(tmp.file("medium-expert"));
  CHECK(i.sources == done.sources);
  CHECK(i.quality == "medium-expert");
  CHECK(i.ref_max_score == 2);
  auto all = a_eps;
  all.insert(all.end(), b_eps.begin(), b_eps.end());
  check_transitions(offline::load_transitions(tmp.file("medium-expert")), all, 5, 2);

  SECTION("inputs of other widths or tasks are refused, naming the input") {
    write(tmp.file("wide"), info_for(6, 2), three(6, 2));
    write(tmp.file("other"), info_for(5, 2, "door_open"), three(5, 2));
    std::string msg =
        error_of([&] { offline::merge({tmp.file("medium"), tmp.file("wide")}, tmp.file("x"), m); });
    CHECK(msg == tmp.file("wide") + ": cannot merge: its obs_dim is 6, " + tmp.file("medium") +
                     "'s is 5");
    msg = error_of(
        [&] { offline::merge({tmp.file("medium"), tmp.file("other")}, tmp.file("x"), m); });
    CHECK(msg == tmp.file("other") + ": cannot merge: its task is 'door_open', " +
                     tmp.file("medium") + "'s is 'hand_over'");
    CHECK(!fs::exists(tmp.file("x")));
    check_no_partial(tmp);
  }
}

TEST_CASE("dataset: export to D4RL's flat layout", "[dataset][offline]") {
  TempDir tmp;
  const auto eps = three(4, 3, 61);
  const DatasetInfo info = write(tmp.file("ds"), info_for(4, 3), eps);
  const std::string out = tmp.file("flat.hdf5");
  offline::export_d4rl(tmp.file("ds"), out);
  CHECK(tmp.list() == std::vector<std::string>{"ds", "flat.hdf5"});

  const offline::Transitions tr = offline::load_transitions(tmp.file("ds"));
  hid_t f = H5Fopen(out.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(f >= 0);
  std::vector<hsize_t> dims;
  const auto obs = h5_read<float>(f, "observations", H5T_NATIVE_FLOAT, dims);
  CHECK(dims == std::vector<hsize_t>{15, 4});
  const auto next = h5_read<float>(f, "next_observations", H5T_NATIVE_FLOAT, dims);
  CHECK(dims == std::vector<hsize_t>{15, 4});
  const auto act = h5_read<float>(f, "actions", H5T_NATIVE_FLOAT, dims);
  CHECK(dims == std::vector<hsize_t>{15, 3});
  const auto rew = h5_read<float>(f, "rewards", H5T_NATIVE_FLOAT, dims);
  CHECK(dims == std::vector<hsize_t>{15});
  const auto term = h5_read<uint8_t>(f, "terminals", H5T_NATIVE_UINT8, dims);
  CHECK(dims == std::vector<hsize_t>{15});
  const auto tout = h5_read<uint8_t>(f, "timeouts", H5T_NATIVE_UINT8, dims);
  CHECK(dims == std::vector<hsize_t>{15});
  for (size_t k = 0; k < 15; ++k) {
    INFO("transition " << k);
    const float* o = tr.observations.data() + tr.obs_row[k] * 4;
    for (size_t c = 0; c < 4; ++c) {
      CHECK(obs[k * 4 + c] == o[c]);
      CHECK(next[k * 4 + c] == o[4 + c]);  // the following row
    }
    for (size_t c = 0; c < 3; ++c) CHECK(act[k * 3 + c] == tr.actions[k * 3 + c]);
    CHECK(rew[k] == tr.rewards[k]);
    CHECK(term[k] == tr.terminations[k]);
    CHECK(tout[k] == tr.truncations[k]);
  }
  CHECK(term[4] == 1);
  CHECK(tout[11] == 1);
  // episode 1's first transition: its own first observation, not episode 0's last
  CHECK(obs[5 * 4] == eps[1].obs[0]);
  CHECK(next[4 * 4] == eps[0].obs[5 * 4]);

  auto attr_text = [&](const char* name) {
    hid_t a = H5Aopen(f, name, H5P_DEFAULT);
    REQUIRE(a >= 0);
    hid_t t = H5Aget_type(a);
    std::string s(H5Tget_size(t), '\0');
    H5Aread(a, t, s.data());
    H5Tclose(t);
    H5Aclose(a);
    return s;
  };
  auto attr_num = [&](const char* name) {
    hid_t a = H5Aopen(f, name, H5P_DEFAULT);
    REQUIRE(a >= 0);
    double v = 0;
    H5Aread(a, H5T_NATIVE_DOUBLE, &v);
    H5Aclose(a);
    return v;
  };
  CHECK(attr_text("dataset_id") == "hand_over/expert-v0");
  CHECK(attr_text("task") == "hand_over");
  CHECK(attr_text("quality") == "expert");
  CHECK(attr_text("checksum") == info.checksum);
  CHECK(attr_num("ref_min_score") == -5.5);
  CHECK(std::isnan(attr_num("ref_max_score")));
  H5Fclose(f);
}

TEST_CASE("dataset: h5py reads the file as Minari's, metadata.json has Minari's keys",
          "[dataset][offline]") {
  TempDir tmp;
  const std::string dir = tmp.file("ds");
  const auto eps = three(4, 2, 71);
  const DatasetInfo info = write(dir, info_for(4, 2), eps);

  // metadata.json: Minari's keys (env_spec and the spaces as JSON text, as Minari writes them)
  const auto j = nlohmann::json::parse(read_file(dir + "/data/metadata.json"));
  for (const char* key :
       {"dataset_id", "env_spec", "observation_space", "action_space", "ref_min_score",
        "ref_max_score", "total_steps", "total_episodes", "algorithm_name", "data_format",
        "task", "task_version", "quality", "obs_dim", "act_dim", "max_episode_steps", "policy",
        "seed", "code_version", "command", "sources", "dropped_episodes", "checksum"}) {
    INFO("key " << key);
    CHECK(j.contains(key));
  }
  CHECK(j["dataset_id"] == "hand_over/expert-v0");
  CHECK(j["total_steps"] == 15);
  CHECK(j["total_episodes"] == 3);
  CHECK(j["data_format"] == "hdf5");
  CHECK(j["ref_min_score"] == -5.5);
  CHECK(j["ref_max_score"].is_null());
  CHECK(j["checksum"] == info.checksum);
  const auto spec = nlohmann::json::parse(j["env_spec"].get<std::string>());
  CHECK(spec["id"] == "hand_over-v0");
  CHECK(spec["max_episode_steps"] == 75);
  CHECK(has(j["observation_space"].get<std::string>(), "\"type\": \"Box\""));
  const auto act_space = nlohmann::json::parse(j["action_space"].get<std::string>());
  CHECK(act_space["shape"] == nlohmann::json::array({2}));
  CHECK(act_space["low"] == nlohmann::json::array({-1.0, -1.0}));
  CHECK(act_space["dtype"] == "float32");

  const std::string python = std::string(BIDEX_SOURCE_DIR) + "/.venv/bin/python";
  if (!fs::exists(python) || run_command(q(python) + " -c 'import h5py'").rc != 0) {
    WARN("no h5py in " << python << ": the h5py check is skipped (scripts/setup.sh installs it)");
    return;
  }
  const std::string script = tmp.file("check.py");
  write_file_atomic(script, R"(import json, sys
import h5py
d = sys.argv[1]
f = h5py.File(d + "/data/main_data.hdf5", "r")
print("root", sorted(f.keys()), int(f.attrs["total_episodes"]), int(f.attrs["total_steps"]),
      f.attrs["dataset_id"].decode())
g = f["episode_0"]
print("keys", sorted(g.keys()))
for k in ["observations", "actions", "rewards", "terminations", "truncations"]:
    print(k, g[k].dtype, g[k].shape)
print("attrs", int(g.attrs["id"]), int(g.attrs["total_steps"]))
print("obs %.9g %.9g" % (g["observations"][0, 0], g["observations"][-1, -1]))
print("act %.9g" % g["actions"][4, 1])
print("rew %.9g" % g["rewards"][2])
print("flags", list(map(bool, g["terminations"][()])),
      list(map(bool, f["episode_1"]["truncations"][()])))
m = json.load(open(d + "/data/metadata.json"))
s = json.loads(m["observation_space"])
print("space", s["type"], s["shape"], s["low"][0], s["high"][-1])
)");
  const CommandResult r = run_command(q(python) + " " + q(script) + " " + q(dir));
  INFO(r.out);
  REQUIRE(r.rc == 0);
  auto num = [](double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.9g", v);
    return std::string(buf);
  };
  CHECK(has(r.out, "root ['episode_0', 'episode_1', 'episode_2'] 3 15 hand_over/expert-v0\n"));
  CHECK(has(r.out, "keys ['actions', 'observations', 'rewards', 'terminations', 'truncations']"));
  CHECK(has(r.out, "observations float32 (6, 4)\n"));
  CHECK(has(r.out, "actions float32 (5, 2)\n"));
  CHECK(has(r.out, "rewards float64 (5,)\n"));
  CHECK(has(r.out, "terminations bool (5,)\n"));
  CHECK(has(r.out, "truncations bool (5,)\n"));
  CHECK(has(r.out, "attrs 0 5\n"));
  CHECK(has(r.out, "obs " + num(eps[0].obs[0]) + " " + num(eps[0].obs[23]) + "\n"));
  CHECK(has(r.out, "act " + num(eps[0].act[9]) + "\n"));
  CHECK(has(r.out, "rew " + num(eps[0].rew[2]) + "\n"));
  CHECK(has(r.out, "flags [False, False, False, False, True] "
                   "[False, False, False, False, False, False, True]\n"));
  CHECK(has(r.out, "space Box [4] -inf inf\n"));
}

TEST_CASE("bidex dataset info | verify | export-d4rl", "[dataset][offline][apps]") {
  TempDir tmp;
  const std::string dir = tmp.file("ds");
  const auto eps = three(4, 2, 81);
  const DatasetInfo info = write(dir, info_for(4, 2), eps);

  CommandResult r = bidex_run("dataset info " + q(dir));
  INFO(r.out);
  CHECK(r.rc == 0);
  CHECK(has(r.out, "hand_over/expert-v0"));
  CHECK(has(r.out, "hand_over (hand_over-v0)"));
  CHECK(has(r.out, "15 steps in 3 episodes"));
  CHECK(has(r.out, "obs 4, act 2"));
  CHECK(has(r.out, "ref_min -5.5"));
  CHECK(has(r.out, info.checksum));
  CHECK(has(r.out, "runs/x/checkpoints/update_000010.ckpt"));

  r = bidex_run("dataset info --json " + q(dir + "/data/main_data.hdf5"));
  CHECK(r.rc == 0);
  CHECK(nlohmann::json::parse(r.out)["checksum"] == info.checksum);

  r = bidex_run("dataset verify " + q(dir));
  CHECK(r.rc == 0);
  CHECK(has(r.out, "OK " + dir));
  CHECK(has(r.out, info.checksum));

  r = bidex_run("dataset export-d4rl " + q(dir) + " " + q(tmp.file("flat.hdf5")));
  CHECK(r.rc == 0);
  CHECK(has(r.out, "15 transitions"));
  CHECK(fs::is_regular_file(tmp.file("flat.hdf5")));

  for (const char* help : {"dataset --help", "dataset info --help", "dataset verify --help",
                           "dataset export-d4rl --help"}) {
    r = bidex_run(help);
    INFO(help << ": " << r.out);
    CHECK(r.rc == 0);
    CHECK(has(r.out, "Usage"));
  }

  // corrupted: status 2 and the message
  flip_data_byte(dir + "/data/main_data.hdf5", eps[2].obs.data() + 4);
  r = bidex_run("dataset verify " + q(dir));
  CHECK(r.rc == 2);
  CHECK(has(r.out, "bidex: error: " + dir + "/data/main_data.hdf5: checksum mismatch"));
  fs::resize_file(dir + "/data/main_data.hdf5", 100);
  r = bidex_run("dataset info " + q(dir));
  CHECK(r.rc == 2);
  CHECK(has(r.out, "not a readable HDF5 file"));
  r = bidex_run("dataset verify " + q(tmp.file("nothing")));
  CHECK(r.rc == 2);
  CHECK(has(r.out, "metadata.json: missing"));
}
