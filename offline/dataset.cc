#include "offline/dataset.h"

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <hdf5.h>
#include <nlohmann/json.hpp>
#include <openssl/evp.h>

#include "core/files.h"
#include "core/version.h"

// Types on disk (Minari's, as h5py writes numpy arrays): observations and actions float32,
// rewards float64, terminations and truncations numpy bool (an 8-bit enum FALSE=0, TRUE=1), the
// episode attributes id and total_steps int64; string attributes are fixed-length UTF-8 (h5py
// reads them as bytes): variable-length ones live in a global heap whose unused bytes are not
// guaranteed to be written, which would break the byte-for-byte reproducibility.
// Files and folders through POSIX rather than std::filesystem (see core/files.cc: LibTorch from
// PyTorch wheels interposes libstdc++'s filesystem functions, and bidex links LibTorch).

namespace bidex::offline {

namespace {

using json = nlohmann::ordered_json;

constexpr const char* kArrays[] = {"observations", "actions", "rewards", "terminations",
                                   "truncations"};

[[noreturn]] void fail(const std::string& what) { throw DatasetError(what); }

// HDF5 prints its error stack to stderr by default; bidex reports errors itself (once, below)
void quiet_hdf5() {
  static const bool done = [] {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    return true;
  }();
  (void)done;
}

// The innermost message of HDF5's error stack, " (HDF5: ...)", or "" when empty; clears it.
std::string hdf5_reason() {
  std::string msg;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_UPWARD,
      [](unsigned n, const H5E_error2_t* e, void* out) -> herr_t {
        if (n == 0 && e->desc) *static_cast<std::string*>(out) = e->desc;
        return 0;
      },
      &msg);
  H5Eclear2(H5E_DEFAULT);
  return msg.empty() ? std::string() : " (HDF5: " + msg + ")";
}

// An HDF5 identifier closed at scope end by the function matching its kind.
class Id {
 public:
  Id() = default;
  Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Id(Id&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Id& operator=(Id&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = o.id_;
      close_ = o.close_;
      o.id_ = -1;
    }
    return *this;
  }
  Id(const Id&) = delete;
  Id& operator=(const Id&) = delete;
  ~Id() { reset(); }
  // Closes now; false when HDF5 reported an error (a file's last writes happen here).
  bool reset() {
    bool ok = true;
    if (id_ >= 0 && close_) ok = close_(id_) >= 0;
    id_ = -1;
    return ok;
  }
  hid_t get() const { return id_; }
  operator hid_t() const { return id_; }

 private:
  hid_t id_ = -1;
  herr_t (*close_)(hid_t) = nullptr;
};

// `id`, or a DatasetError "FILE: WHAT (HDF5: ...)" when it is negative.
Id checked(hid_t id, herr_t (*close)(hid_t), const std::string& file, const std::string& what) {
  if (id < 0) fail(file + ": " + what + hdf5_reason());
  return Id(id, close);
}
void check(herr_t r, const std::string& file, const std::string& what) {
  if (r < 0) fail(file + ": " + what + hdf5_reason());
}

// ---------------------------------------------------------------------------------------------
// files and folders

std::string strip_slashes(std::string p) {
  while (p.size() > 1 && p.back() == '/') p.pop_back();
  return p;
}

std::string parent_of(const std::string& path) {
  const std::string p = strip_slashes(path);
  const size_t slash = p.rfind('/');
  if (slash == std::string::npos) return p == "." ? ".." : ".";
  if (slash == 0) return "/";
  return p.substr(0, slash);
}

bool is_dir(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}
bool is_file(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}
bool exists(const std::string& p) {
  struct stat st;
  return ::lstat(p.c_str(), &st) == 0;
}

bool empty_dir(const std::string& p) {
  DIR* d = ::opendir(p.c_str());
  if (!d) return false;
  bool empty = true;
  while (dirent* e = ::readdir(d)) {
    if (std::strcmp(e->d_name, ".") != 0 && std::strcmp(e->d_name, "..") != 0) {
      empty = false;
      break;
    }
  }
  ::closedir(d);
  return empty;
}

// rm -r, best effort (it cleans up after a failure that is already being reported)
void remove_tree(const std::string& p) {
  struct stat st;
  if (::lstat(p.c_str(), &st) != 0) return;
  if (S_ISDIR(st.st_mode)) {
    if (DIR* d = ::opendir(p.c_str())) {
      while (dirent* e = ::readdir(d)) {
        if (std::strcmp(e->d_name, ".") == 0 || std::strcmp(e->d_name, "..") == 0) continue;
        remove_tree(p + "/" + e->d_name);
      }
      ::closedir(d);
    }
    ::rmdir(p.c_str());
  } else {
    ::unlink(p.c_str());
  }
}

// mkdir -p
void make_folders(const std::string& dir) {
  const std::string d = strip_slashes(dir);
  for (size_t pos = d.find('/', 1);; pos = d.find('/', pos + 1)) {
    const std::string part = pos == std::string::npos ? d : d.substr(0, pos);
    if (::mkdir(part.c_str(), 0755) != 0 && errno != EEXIST)
      fail(dir + ": cannot create folder " + part + ": " + std::strerror(errno));
    if (pos == std::string::npos) break;
  }
}

std::string sha256_of(const std::string& file) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(file.c_str(), "rb"), std::fclose);
  if (!f) fail(file + ": cannot open for reading: " + std::strerror(errno));
  std::unique_ptr<EVP_MD_CTX, void (*)(EVP_MD_CTX*)> ctx(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  if (!ctx || EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) != 1)
    fail(file + ": cannot start a SHA-256 digest (OpenSSL)");
  std::vector<unsigned char> buf(1 << 20);
  size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), f.get())) > 0)
    EVP_DigestUpdate(ctx.get(), buf.data(), n);
  if (std::ferror(f.get())) fail(file + ": read failed while hashing: " + std::strerror(errno));
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned len = 0;
  EVP_DigestFinal_ex(ctx.get(), md, &len);
  std::string out = "sha256:";
  char hex[3];
  for (unsigned i = 0; i < len; ++i) {
    std::snprintf(hex, sizeof hex, "%02x", md[i]);
    out += hex;
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// metadata.json

std::string box_json(int64_t n, const char* low, const char* high) {
  // Minari serialises a gymnasium Box as this JSON text (Python's json.dumps: Infinity allowed)
  std::string lows, highs;
  for (int64_t i = 0; i < n; ++i) {
    lows.append(i ? ", " : "").append(low);
    highs.append(i ? ", " : "").append(high);
  }
  return std::string(R"({"type": "Box", "dtype": "float32", "shape": [)") + std::to_string(n) +
         R"(], "low": [)" + lows + R"(], "high": [)" + highs + "]}";
}

json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

// Minari's keys first (env_spec and the spaces as JSON text, as Minari writes them), then bidex's.
std::string metadata_text(const DatasetInfo& i) {
  json spec = {{"id", i.task_version},
               {"entry_point", nullptr},
               {"reward_threshold", nullptr},
               {"nondeterministic", false},
               {"max_episode_steps", i.max_episode_steps},
               {"order_enforce", true},
               {"disable_env_checker", false},
               {"kwargs", json::object()},
               {"additional_wrappers", json::array()},
               {"vector_entry_point", nullptr}};
  json j;
  j["dataset_id"] = i.dataset_id;
  j["total_episodes"] = i.total_episodes;
  j["total_steps"] = i.total_steps;
  j["data_format"] = "hdf5";
  j["env_spec"] = spec.dump();
  j["observation_space"] = box_json(i.obs_dim, "-Infinity", "Infinity");
  j["action_space"] = box_json(i.act_dim, "-1.0", "1.0");
  j["ref_min_score"] = number_or_null(i.ref_min_score);
  j["ref_max_score"] = number_or_null(i.ref_max_score);
  j["algorithm_name"] = i.algorithm_name;
  j["task"] = i.task;
  j["task_version"] = i.task_version;
  j["quality"] = i.quality;
  j["obs_dim"] = i.obs_dim;
  j["act_dim"] = i.act_dim;
  j["max_episode_steps"] = i.max_episode_steps;
  j["policy"] = i.policy;
  j["seed"] = i.seed;
  j["code_version"] = i.code_version;
  j["command"] = i.command;
  j["sources"] = i.sources;
  j["dropped_episodes"] = i.dropped_episodes;
  j["checksum"] = i.checksum;
  return j.dump(2) + "\n";
}

template <class T>
T get_key(const json& j, const char* key, const std::string& file) {
  const auto it = j.find(key);
  if (it == j.end()) fail(file + ": lacks the key '" + key + "'");
  try {
    return it->get<T>();
  } catch (const std::exception&) {
    fail(file + ": key '" + key + "': unexpected value " + it->dump());
  }
}

double score_key(const json& j, const char* key, const std::string& file) {
  const auto it = j.find(key);
  if (it == j.end()) fail(file + ": lacks the key '" + key + "'");
  if (it->is_null()) return NAN;
  if (!it->is_number()) fail(file + ": key '" + key + "': expected a number or null, got " +
                             it->dump());
  return it->get<double>();
}

DatasetInfo parse_metadata(const std::string& file) {
  if (!exists(file)) fail(file + ": missing (not a dataset folder?)");
  std::string text;
  try {
    text = read_file(file);
  } catch (const Error& e) {
    fail(e.what());
  }
  json j;
  try {
    j = json::parse(text);
  } catch (const std::exception& e) {
    fail(file + ": not valid JSON (" + e.what() + ")");
  }
  if (!j.is_object()) fail(file + ": expected a JSON object, got " + std::string(j.type_name()));
  DatasetInfo i;
  i.dataset_id = get_key<std::string>(j, "dataset_id", file);
  i.task = get_key<std::string>(j, "task", file);
  i.task_version = get_key<std::string>(j, "task_version", file);
  i.quality = get_key<std::string>(j, "quality", file);
  i.obs_dim = get_key<int64_t>(j, "obs_dim", file);
  i.act_dim = get_key<int64_t>(j, "act_dim", file);
  i.max_episode_steps = get_key<int>(j, "max_episode_steps", file);
  i.ref_min_score = score_key(j, "ref_min_score", file);
  i.ref_max_score = score_key(j, "ref_max_score", file);
  i.policy = get_key<std::string>(j, "policy", file);
  i.algorithm_name = get_key<std::string>(j, "algorithm_name", file);
  i.seed = get_key<uint64_t>(j, "seed", file);
  i.code_version = get_key<std::string>(j, "code_version", file);
  i.command = get_key<std::string>(j, "command", file);
  i.sources = get_key<std::vector<std::string>>(j, "sources", file);
  i.total_steps = get_key<int64_t>(j, "total_steps", file);
  i.total_episodes = get_key<int64_t>(j, "total_episodes", file);
  i.dropped_episodes = get_key<int64_t>(j, "dropped_episodes", file);
  i.checksum = get_key<std::string>(j, "checksum", file);
  const std::string format = get_key<std::string>(j, "data_format", file);
  if (format != "hdf5") fail(file + ": data_format: expected \"hdf5\", got \"" + format + "\"");
  if (i.obs_dim <= 0 || i.act_dim <= 0)
    fail(file + ": expected obs_dim and act_dim > 0, got " + std::to_string(i.obs_dim) + " and " +
         std::to_string(i.act_dim));
  if (i.total_steps < 0 || i.total_episodes < 0)
    fail(file + ": expected total_steps and total_episodes >= 0, got " +
         std::to_string(i.total_steps) + " and " + std::to_string(i.total_episodes));
  if (i.checksum.size() != 7 + 64 || i.checksum.rfind("sha256:", 0) != 0)
    fail(file + ": checksum: expected \"sha256:\" and 64 hex digits, got \"" + i.checksum + "\"");
  return i;
}

// ---------------------------------------------------------------------------------------------
// HDF5 pieces shared by the writers and readers

// numpy's bool as h5py stores it
Id bool_type(const std::string& file) {
  Id t = checked(H5Tenum_create(H5T_NATIVE_INT8), H5Tclose, file, "cannot make the bool type");
  const int8_t f = 0, t1 = 1;
  check(H5Tenum_insert(t, "FALSE", &f), file, "cannot make the bool type");
  check(H5Tenum_insert(t, "TRUE", &t1), file, "cannot make the bool type");
  return t;
}

// Creation settings of a reproducible file: fixed format versions, no object time stamps (the
// root group takes its settings from the file creation list), no fill pass before the data.
struct Plists {
  Id fcpl, fapl, gcpl, dcpl;
  explicit Plists(const std::string& file) {
    fcpl = checked(H5Pcreate(H5P_FILE_CREATE), H5Pclose, file, "cannot create property list");
    fapl = checked(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, file, "cannot create property list");
    gcpl = checked(H5Pcreate(H5P_GROUP_CREATE), H5Pclose, file, "cannot create property list");
    dcpl = checked(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, file, "cannot create property list");
    check(H5Pset_obj_track_times(fcpl, false), file, "cannot turn off time stamps");
    check(H5Pset_obj_track_times(gcpl, false), file, "cannot turn off time stamps");
    check(H5Pset_obj_track_times(dcpl, false), file, "cannot turn off time stamps");
    check(H5Pset_fill_time(dcpl, H5D_FILL_TIME_NEVER), file, "cannot set the fill time");
    check(H5Pset_libver_bounds(fapl, H5F_LIBVER_V18, H5F_LIBVER_V18), file,
          "cannot set the format versions");
    // closing the file closes whatever is still open in it, so the close really writes it
    check(H5Pset_fclose_degree(fapl, H5F_CLOSE_STRONG), file, "cannot set the close degree");
  }
};

Id create_file(const std::string& file, const Plists& pl, unsigned flags) {
  return checked(H5Fcreate(file.c_str(), flags, pl.fcpl, pl.fapl), H5Fclose, file,
                 "cannot create the HDF5 file");
}

void close_file(Id& f, const std::string& file) {
  if (!f.reset()) fail(file + ": writing the HDF5 file failed at close" + hdf5_reason());
}

// A new dataset of `rows` (x `cols` when cols > 0), written whole from `data` when rows > 0.
void write_array(hid_t loc, const char* name, hid_t file_type, hid_t mem_type, hsize_t rows,
                 hsize_t cols, const void* data, const Plists& pl, const std::string& file,
                 const std::string& where) {
  const hsize_t dims[2] = {rows, cols};
  Id space = checked(H5Screate_simple(cols > 0 ? 2 : 1, dims, nullptr), H5Sclose, file,
                     where + name + ": cannot create its dataspace");
  Id ds = checked(H5Dcreate2(loc, name, file_type, space, H5P_DEFAULT, pl.dcpl, H5P_DEFAULT),
                  H5Dclose, file, where + name + ": cannot create");
  if (rows > 0 && data)
    check(H5Dwrite(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), file,
          where + name + ": write failed");
}

void attr_i64(hid_t obj, const char* name, int64_t v, const std::string& file) {
  Id space = checked(H5Screate(H5S_SCALAR), H5Sclose, file, "cannot create a dataspace");
  Id a = checked(H5Acreate2(obj, name, H5T_STD_I64LE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                 file, std::string("cannot create attribute ") + name);
  check(H5Awrite(a, H5T_NATIVE_INT64, &v), file, std::string("cannot write attribute ") + name);
}
void attr_f64(hid_t obj, const char* name, double v, const std::string& file) {
  Id space = checked(H5Screate(H5S_SCALAR), H5Sclose, file, "cannot create a dataspace");
  Id a = checked(H5Acreate2(obj, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                 file, std::string("cannot create attribute ") + name);
  check(H5Awrite(a, H5T_NATIVE_DOUBLE, &v), file, std::string("cannot write attribute ") + name);
}
void attr_str(hid_t obj, const char* name, const std::string& v, const std::string& file) {
  Id type = checked(H5Tcopy(H5T_C_S1), H5Tclose, file, "cannot create a string type");
  check(H5Tset_size(type, std::max<size_t>(1, v.size())), file, "cannot size a string type");
  check(H5Tset_strpad(type, H5T_STR_NULLPAD), file, "cannot set a string's padding");
  check(H5Tset_cset(type, H5T_CSET_UTF8), file, "cannot set a string's character set");
  Id space = checked(H5Screate(H5S_SCALAR), H5Sclose, file, "cannot create a dataspace");
  Id a = checked(H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose, file,
                 std::string("cannot create attribute ") + name);
  const std::string padded = v.empty() ? std::string(1, '\0') : v;
  check(H5Awrite(a, type, padded.data()), file, std::string("cannot write attribute ") + name);
}

std::string episode_name(int64_t i) { return "episode_" + std::to_string(i); }

// ---------------------------------------------------------------------------------------------
// reading

// A dataset whose metadata and HDF5 structure agree, with its file open.
struct Opened {
  std::string dir, meta, h5;
  DatasetInfo info;
  std::vector<int64_t> lengths;  // steps of each episode
  Id file;
};

std::vector<hsize_t> shape_of(hid_t ds, const std::string& file, const std::string& where) {
  Id space = checked(H5Dget_space(ds), H5Sclose, file, where + ": cannot read its shape");
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 0) fail(file + ": " + where + ": cannot read its shape" + hdf5_reason());
  std::vector<hsize_t> dims(static_cast<size_t>(rank));
  if (rank > 0) H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  return dims;
}

std::string shape_text(const std::vector<hsize_t>& d) {
  std::string s = "(";
  for (size_t i = 0; i < d.size(); ++i)
    s.append(i ? ", " : "").append(std::to_string(d[i]));
  return s + (d.size() == 1 ? ",)" : ")");
}

// The type class an array must have: float for observations, actions and rewards; an 8-bit
// enum (numpy bool) or an integer for the flags.
void check_type(hid_t ds, const char* name, const std::string& file, const std::string& where) {
  Id type = checked(H5Dget_type(ds), H5Tclose, file, where + ": cannot read its type");
  const H5T_class_t c = H5Tget_class(type);
  const bool flags =
      std::strcmp(name, "terminations") == 0 || std::strcmp(name, "truncations") == 0;
  if (!flags && c != H5T_FLOAT) fail(file + ": " + where + ": expected floating-point values");
  if (flags && c != H5T_ENUM && c != H5T_INTEGER)
    fail(file + ": " + where + ": expected booleans (an 8-bit enum or integers)");
}

void open_file(Opened& o) {
  if (!exists(o.h5)) fail(o.h5 + ": missing");
  const htri_t is = H5Fis_hdf5(o.h5.c_str());
  hid_t f = is > 0 ? H5Fopen(o.h5.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT) : -1;
  if (f < 0) fail(o.h5 + ": not a readable HDF5 file (truncated or corrupted?)" + hdf5_reason());
  o.file = Id(f, H5Fclose);
}

// metadata.json, then the HDF5 structure against it
Opened open_checked(const std::string& path) {
  quiet_hdf5();
  Opened o;
  o.dir = dataset_dir(path);
  o.meta = o.dir + "/data/metadata.json";
  o.h5 = o.dir + "/data/main_data.hdf5";
  o.info = parse_metadata(o.meta);
  open_file(o);
  const DatasetInfo& info = o.info;
  H5G_info_t root;
  check(H5Gget_info(o.file, &root), o.h5, "cannot list the root group");
  if (static_cast<int64_t>(root.nlinks) != info.total_episodes)
    fail(o.h5 + ": holds " + std::to_string(root.nlinks) + " episode groups, " + o.meta +
         " counts " + std::to_string(info.total_episodes));
  int64_t total = 0;
  o.lengths.reserve(static_cast<size_t>(info.total_episodes));
  for (int64_t e = 0; e < info.total_episodes; ++e) {
    const std::string ep = episode_name(e);
    if (H5Lexists(o.file, ep.c_str(), H5P_DEFAULT) <= 0) {
      hdf5_reason();
      fail(o.h5 + ": " + ep + ": missing (" + o.meta + " counts " +
           std::to_string(info.total_episodes) + " episodes)");
    }
    Id g = checked(H5Gopen2(o.file, ep.c_str(), H5P_DEFAULT), H5Gclose, o.h5,
                   ep + ": cannot open the group");
    int64_t steps = -1;
    for (const char* name : kArrays) {
      const std::string where = ep + "/" + name;
      if (H5Lexists(g, name, H5P_DEFAULT) <= 0) {
        hdf5_reason();
        fail(o.h5 + ": " + where + ": missing");
      }
      Id ds = checked(H5Dopen2(g, name, H5P_DEFAULT), H5Dclose, o.h5, where + ": cannot open");
      check_type(ds, name, o.h5, where);
      const auto dims = shape_of(ds, o.h5, where);
      const bool obs = std::strcmp(name, "observations") == 0;
      const bool act = std::strcmp(name, "actions") == 0;
      if (steps < 0) {  // observations come first: T + 1 rows
        if (dims.size() != 2 || dims[0] < 2)
          fail(o.h5 + ": " + where + ": expected shape (T + 1, " + std::to_string(info.obs_dim) +
               ") with T >= 1, got " + shape_text(dims));
        steps = static_cast<int64_t>(dims[0]) - 1;
      }
      std::vector<hsize_t> want;
      const hsize_t t = static_cast<hsize_t>(steps);
      if (obs) want = {t + 1, static_cast<hsize_t>(info.obs_dim)};
      else if (act) want = {t, static_cast<hsize_t>(info.act_dim)};
      else want = {t};
      if (dims != want)
        fail(o.h5 + ": " + where + ": expected shape " + shape_text(want) + ", got " +
             shape_text(dims));
    }
    if (H5Aexists(g, "total_steps") > 0) {
      Id a = checked(H5Aopen(g, "total_steps", H5P_DEFAULT), H5Aclose, o.h5,
                     ep + ": cannot open attribute total_steps");
      int64_t v = 0;
      check(H5Aread(a, H5T_NATIVE_INT64, &v), o.h5, ep + ": cannot read attribute total_steps");
      if (v != steps)
        fail(o.h5 + ": " + ep + ": attribute total_steps: expected " + std::to_string(steps) +
             " (the rows of its arrays), got " + std::to_string(v));
    }
    hdf5_reason();
    o.lengths.push_back(steps);
    total += steps;
  }
  if (total != info.total_steps)
    fail(o.h5 + ": its episodes hold " + std::to_string(total) + " steps, " + o.meta +
         " counts " + std::to_string(info.total_steps));
  return o;
}

void check_sum(const Opened& o) {
  const std::string actual = sha256_of(o.h5);
  if (actual != o.info.checksum)
    fail(o.h5 + ": checksum mismatch (corrupted or modified): expected " + o.info.checksum +
         " (" + o.meta + "), got " + actual);
}

// One episode's arrays read straight into the destination buffers (HDF5 converts the types).
void read_episode(const Opened& o, int64_t e, float* obs, float* act, float* rew, uint8_t* term,
                  uint8_t* trunc, hid_t bool_t) {
  const std::string ep = episode_name(e);
  Id g = checked(H5Gopen2(o.file, ep.c_str(), H5P_DEFAULT), H5Gclose, o.h5,
                 ep + ": cannot open the group");
  auto read = [&](const char* name, hid_t mem_type, void* dst) {
    const std::string where = ep + "/" + name;
    Id ds = checked(H5Dopen2(g, name, H5P_DEFAULT), H5Dclose, o.h5, where + ": cannot open");
    if (mem_type < 0) {  // a flag: numpy bool (enum) or integers
      Id type = checked(H5Dget_type(ds), H5Tclose, o.h5, where + ": cannot read its type");
      mem_type = H5Tget_class(type) == H5T_ENUM ? bool_t : H5T_NATIVE_UINT8;
    }
    check(H5Dread(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, dst), o.h5,
          where + ": read failed");
  };
  read("observations", H5T_NATIVE_FLOAT, obs);
  read("actions", H5T_NATIVE_FLOAT, act);
  read("rewards", H5T_NATIVE_FLOAT, rew);
  read("terminations", -1, term);
  read("truncations", -1, trunc);
}

// One episode in memory (merge and export go episode by episode).
struct Episode {
  std::vector<float> obs, act, rew;
  std::vector<uint8_t> term, trunc;
  void read(const Opened& o, int64_t e, hid_t bool_t) {
    const auto t = static_cast<size_t>(o.lengths[static_cast<size_t>(e)]);
    obs.resize((t + 1) * static_cast<size_t>(o.info.obs_dim));
    act.resize(t * static_cast<size_t>(o.info.act_dim));
    rew.resize(t);
    term.resize(t);
    trunc.resize(t);
    read_episode(o, e, obs.data(), act.data(), rew.data(), term.data(), trunc.data(), bool_t);
  }
};

}  // namespace

const std::vector<std::string>& qualities() {
  static const std::vector<std::string> q = {"random", "replay", "medium", "expert",
                                             "medium-expert"};
  return q;
}

std::string dataset_dir(const std::string& path) {
  const std::string p = strip_slashes(path);
  if (is_file(p)) return parent_of(parent_of(p));  // DIR/data/main_data.hdf5
  if (is_dir(p) && is_file(p + "/main_data.hdf5")) return parent_of(p);  // DIR/data
  return p;
}

// ---------------------------------------------------------------------------------------------
// DatasetWriter

struct DatasetWriter::Impl {
  std::string dir, tmp, h5;
  DatasetInfo info;
  Plists plists;
  Id file, bool_t;
  int64_t steps = 0, episodes = 0, dropped = 0;
  bool finished = false, broken = false;
  std::vector<double> rewards;  // float64 on disk

  Impl(const std::string& d, const DatasetInfo& i)
      : dir(strip_slashes(d)), info(i), plists(strip_slashes(d)) {}
};

DatasetWriter::DatasetWriter(const std::string& dir, const DatasetInfo& info) {
  quiet_hdf5();
  if (info.obs_dim <= 0 || info.act_dim <= 0)
    fail(dir + ": a dataset needs obs_dim and act_dim > 0, got " + std::to_string(info.obs_dim) +
         " and " + std::to_string(info.act_dim));
  auto impl = std::make_unique<Impl>(dir, info);
  const std::string& d = impl->dir;
  if (exists(d) && !(is_dir(d) && empty_dir(d)))
    fail(d + ": already exists and is not an empty folder (nothing there was touched)");
  make_folders(parent_of(d));
  // a fresh temporary sibling: the process id and a counter, as a killed writer's may remain
  static std::atomic<int> counter{0};
  for (;;) {
    impl->tmp = d + ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
    if (::mkdir(impl->tmp.c_str(), 0755) == 0) break;
    if (errno != EEXIST) fail(impl->tmp + ": cannot create folder: " + std::strerror(errno));
  }
  try {
    if (::mkdir((impl->tmp + "/data").c_str(), 0755) != 0)
      fail(impl->tmp + "/data: cannot create folder: " + std::strerror(errno));
    impl->h5 = impl->tmp + "/data/main_data.hdf5";
    impl->file = create_file(impl->h5, impl->plists, H5F_ACC_EXCL);
    impl->bool_t = bool_type(impl->h5);
  } catch (...) {
    impl->file.reset();
    hdf5_reason();
    remove_tree(impl->tmp);
    throw;
  }
  impl_ = std::move(impl);  // from here on the destructor removes the temporary folder
}

DatasetWriter::~DatasetWriter() {
  if (!impl_ || impl_->finished) return;
  impl_->file.reset();
  hdf5_reason();
  remove_tree(impl_->tmp);
}

bool DatasetWriter::add_episode(const float* observations, const float* actions,
                                const float* rewards, const uint8_t* terminations,
                                const uint8_t* truncations, int64_t steps) {
  Impl& w = *impl_;
  const std::string ep = episode_name(w.episodes);
  if (w.finished || w.broken)
    fail(w.dir + ": add_episode after finish() or after a failed write");
  if (steps < 1) fail(w.dir + ": " + ep + ": expected >= 1 steps, got " + std::to_string(steps));
  if (!observations || !actions || !rewards || !terminations || !truncations)
    fail(w.dir + ": " + ep + ": an array is missing (null pointer)");
  const auto t = static_cast<size_t>(steps);
  const size_t nobs = (t + 1) * static_cast<size_t>(w.info.obs_dim);
  const size_t nact = t * static_cast<size_t>(w.info.act_dim);
  for (size_t i = 0; i < t; ++i) {
    if (terminations[i] > 1 || truncations[i] > 1)
      fail(w.dir + ": " + ep + ": step " + std::to_string(i) +
           ": expected terminations and truncations 0 or 1, got " +
           std::to_string(terminations[i]) + " and " + std::to_string(truncations[i]));
    if (i + 1 < t && (terminations[i] || truncations[i]))
      fail(w.dir + ": " + ep + ": step " + std::to_string(i) + " of " + std::to_string(t) +
           " ends the episode (only the last step may terminate or truncate)");
  }
  auto finite = [](const float* p, size_t n) {
    for (size_t i = 0; i < n; ++i)
      if (!std::isfinite(p[i])) return false;
    return true;
  };
  if (!finite(observations, nobs) || !finite(actions, nact) || !finite(rewards, t)) {
    ++w.dropped;
    return false;
  }
  w.rewards.assign(rewards, rewards + t);
  w.broken = true;  // until the episode is complete
  {
    Id g = checked(H5Gcreate2(w.file, ep.c_str(), H5P_DEFAULT, w.plists.gcpl, H5P_DEFAULT),
                   H5Gclose, w.h5, ep + ": cannot create the group");
    const std::string where = ep + "/";
    write_array(g, "observations", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, t + 1,
                static_cast<hsize_t>(w.info.obs_dim), observations, w.plists, w.h5, where);
    write_array(g, "actions", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, t,
                static_cast<hsize_t>(w.info.act_dim), actions, w.plists, w.h5, where);
    write_array(g, "rewards", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, t, 0, w.rewards.data(), w.plists,
                w.h5, where);
    write_array(g, "terminations", w.bool_t, w.bool_t, t, 0, terminations, w.plists, w.h5, where);
    write_array(g, "truncations", w.bool_t, w.bool_t, t, 0, truncations, w.plists, w.h5, where);
    attr_i64(g, "id", w.episodes, w.h5);
    attr_i64(g, "total_steps", steps, w.h5);
    if (!g.reset()) fail(w.h5 + ": " + ep + ": cannot close the group" + hdf5_reason());
  }
  w.broken = false;
  ++w.episodes;
  w.steps += steps;
  return true;
}

int64_t DatasetWriter::steps() const { return impl_->steps; }
int64_t DatasetWriter::episodes() const { return impl_->episodes; }

DatasetInfo DatasetWriter::finish() {
  Impl& w = *impl_;
  if (w.finished || w.broken) fail(w.dir + ": finish() after finish() or after a failed write");
  DatasetInfo& info = w.info;
  info.total_steps = w.steps;
  info.total_episodes = w.episodes;
  info.dropped_episodes = w.dropped;
  if (info.code_version.empty()) info.code_version = code_version();
  w.broken = true;  // a failure below leaves nothing usable: the destructor cleans up
  attr_i64(w.file, "total_episodes", w.episodes, w.h5);
  attr_i64(w.file, "total_steps", w.steps, w.h5);
  attr_str(w.file, "dataset_id", info.dataset_id, w.h5);
  w.bool_t.reset();
  close_file(w.file, w.h5);
  info.checksum = sha256_of(w.h5);
  try {
    write_file_atomic(w.tmp + "/data/metadata.json", metadata_text(info));
  } catch (const Error& e) {
    fail(e.what());
  }
  // rename() replaces an empty folder but not a non-empty one
  if (std::rename(w.tmp.c_str(), w.dir.c_str()) != 0)
    fail(w.dir + ": cannot move the finished dataset into place from " + w.tmp + ": " +
         std::strerror(errno));
  w.finished = true;
  w.broken = false;
  return info;
}

// ---------------------------------------------------------------------------------------------
// reading, export, merge

DatasetInfo read_info(const std::string& path) { return open_checked(path).info; }

DatasetInfo verify(const std::string& path) {
  Opened o = open_checked(path);
  check_sum(o);
  return o.info;
}

Transitions load_transitions(const std::string& path, bool verify_sum) {
  Opened o = open_checked(path);
  if (verify_sum) check_sum(o);
  Transitions tr;
  tr.info = o.info;
  const auto n = static_cast<size_t>(o.info.total_steps);
  const auto eps = o.lengths.size();
  const auto od = static_cast<size_t>(o.info.obs_dim), ad = static_cast<size_t>(o.info.act_dim);
  tr.steps = o.info.total_steps;
  tr.observations.resize((n + eps) * od);
  tr.actions.resize(n * ad);
  tr.rewards.resize(n);
  tr.terminations.resize(n);
  tr.truncations.resize(n);
  tr.obs_row.resize(n);
  Id bool_t = bool_type(o.h5);
  size_t step = 0, row = 0;
  for (size_t e = 0; e < eps; ++e) {
    const auto t = static_cast<size_t>(o.lengths[e]);
    read_episode(o, static_cast<int64_t>(e), tr.observations.data() + row * od,
                 tr.actions.data() + step * ad, tr.rewards.data() + step,
                 tr.terminations.data() + step, tr.truncations.data() + step, bool_t);
    for (size_t i = 0; i < t; ++i) tr.obs_row[step + i] = static_cast<int64_t>(row + i);
    step += t;
    row += t + 1;
  }
  return tr;
}

void export_d4rl(const std::string& path, const std::string& out_file) {
  Opened o = open_checked(path);
  check_sum(o);
  const std::string tmp = out_file + ".tmp." + std::to_string(::getpid());
  const auto n = static_cast<hsize_t>(o.info.total_steps);
  const auto od = static_cast<hsize_t>(o.info.obs_dim), ad = static_cast<hsize_t>(o.info.act_dim);
  try {
    Plists pl(out_file);
    Id f = create_file(tmp, pl, H5F_ACC_TRUNC);
    Id bool_t = bool_type(out_file);
    struct Out {
      const char* name;
      hid_t file_type, mem_type;
      hsize_t cols;
      Id ds;
    };
    Out outs[] = {{"observations", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, od, {}},
                  {"next_observations", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, od, {}},
                  {"actions", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, ad, {}},
                  {"rewards", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, 0, {}},
                  {"terminals", bool_t, bool_t, 0, {}},
                  {"timeouts", bool_t, bool_t, 0, {}}};
    for (auto& x : outs) {
      const hsize_t dims[2] = {n, x.cols};
      Id space = checked(H5Screate_simple(x.cols ? 2 : 1, dims, nullptr), H5Sclose, out_file,
                         std::string(x.name) + ": cannot create its dataspace");
      x.ds = checked(H5Dcreate2(f, x.name, x.file_type, space, H5P_DEFAULT, pl.dcpl, H5P_DEFAULT),
                     H5Dclose, out_file, std::string(x.name) + ": cannot create");
    }
    // episode by episode into rows [at, at + T) of each array: the observations are rows 0..T-1
    // of the episode's, the next observations rows 1..T
    Episode ep;
    hsize_t at = 0;
    for (size_t e = 0; e < o.lengths.size(); ++e) {
      ep.read(o, static_cast<int64_t>(e), bool_t);
      const auto t = static_cast<hsize_t>(o.lengths[e]);
      const void* src[] = {ep.obs.data(),  ep.obs.data() + od, ep.act.data(),
                           ep.rew.data(),  ep.term.data(),     ep.trunc.data()};
      for (size_t k = 0; k < 6; ++k) {
        Out& x = outs[k];
        const hsize_t start[2] = {at, 0}, count[2] = {t, x.cols};
        const int rank = x.cols ? 2 : 1;
        Id mem = checked(H5Screate_simple(rank, count, nullptr), H5Sclose, out_file,
                         std::string(x.name) + ": cannot create a dataspace");
        Id file_space = checked(H5Dget_space(x.ds), H5Sclose, out_file,
                                std::string(x.name) + ": cannot read its dataspace");
        check(H5Sselect_hyperslab(file_space, H5S_SELECT_SET, start, nullptr, count, nullptr),
              out_file, std::string(x.name) + ": cannot select rows");
        check(H5Dwrite(x.ds, x.mem_type, mem, file_space, H5P_DEFAULT, src[k]), out_file,
              std::string(x.name) + ": write failed");
      }
      at += t;
    }
    for (auto& x : outs) x.ds.reset();
    attr_str(f, "dataset_id", o.info.dataset_id, out_file);
    attr_str(f, "task", o.info.task, out_file);
    attr_str(f, "quality", o.info.quality, out_file);
    attr_str(f, "checksum", o.info.checksum, out_file);
    attr_f64(f, "ref_min_score", o.info.ref_min_score, out_file);
    attr_f64(f, "ref_max_score", o.info.ref_max_score, out_file);
    bool_t.reset();
    close_file(f, out_file);
  } catch (...) {
    hdf5_reason();
    ::unlink(tmp.c_str());
    throw;
  }
  if (std::rename(tmp.c_str(), out_file.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    fail(out_file + ": rename failed: " + std::strerror(err));
  }
}

DatasetInfo merge(const std::vector<std::string>& inputs, const std::string& dir,
                  DatasetInfo info) {
  if (inputs.empty()) fail(dir + ": merge needs at least one input dataset");
  std::vector<Opened> in;
  for (auto& p : inputs) {
    in.push_back(open_checked(p));
    check_sum(in.back());
  }
  const Opened& first = in.front();
  for (size_t k = 1; k < in.size(); ++k) {
    const DatasetInfo& a = first.info;
    const DatasetInfo& b = in[k].info;
    auto differs = [&](const std::string& what, const std::string& va, const std::string& vb) {
      fail(in[k].dir + ": cannot merge: its " + what + " is " + vb + ", " + first.dir + "'s is " +
           va);
    };
    if (b.task != a.task) differs("task", "'" + a.task + "'", "'" + b.task + "'");
    if (b.obs_dim != a.obs_dim)
      differs("obs_dim", std::to_string(a.obs_dim), std::to_string(b.obs_dim));
    if (b.act_dim != a.act_dim)
      differs("act_dim", std::to_string(a.act_dim), std::to_string(b.act_dim));
  }
  info.task = first.info.task;
  info.task_version = first.info.task_version;
  info.obs_dim = first.info.obs_dim;
  info.act_dim = first.info.act_dim;
  if (info.max_episode_steps == 0) info.max_episode_steps = first.info.max_episode_steps;
  info.sources.clear();
  for (auto& o : in) info.sources.push_back(o.info.dataset_id + " " + o.info.checksum);
  if (info.policy.empty()) {
    for (auto& o : in) info.policy += (info.policy.empty() ? "" : " + ") + o.info.policy;
  }
  DatasetWriter w(dir, info);
  Id bool_t = bool_type(dir);
  Episode ep;
  for (auto& o : in) {
    for (size_t e = 0; e < o.lengths.size(); ++e) {
      ep.read(o, static_cast<int64_t>(e), bool_t);
      w.add_episode(ep.obs.data(), ep.act.data(), ep.rew.data(), ep.term.data(), ep.trunc.data(),
                    o.lengths[e]);
    }
    o.file.reset();
  }
  return w.finish();
}

}  // namespace bidex::offline
