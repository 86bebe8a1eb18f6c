// bidex._bidex: the Python module over the C++ core's packs, the same env API that bidex's own
// learners step (python/README.md): taskpack::TaskPack on the CPU, and taskpack::WarpPack on the
// GPU backend (MuJoCo Warp, driven from this process's own interpreter), and the multi-agent
// splits of marl/split.h. It links sim, tasks, taskpack and marl_split, never LibTorch. The
// pack's result rows are handed over without a copy: numpy arrays of the CPU pack's host rows,
// DLPack arrays (torch.from_dlpack, numpy.from_dlpack) of the GPU pack's device rows. step()
// releases the GIL while the pack steps.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/unique_ptr.h>
#include <nanobind/stl/array.h>
#include <nanobind/stl/vector.h>

#include <memory>
#include <string>
#include <vector>

#include "core/error.h"
#include "marl/spec_json.h"
#include "sim/render.h"
#include "taskpack/pack.h"
#include "taskpack/suite.h"
#include "taskpack/warp_pack.h"
#include "tasks/registry.h"

namespace nb = nanobind;
using namespace nb::literals;

namespace {

using bidex::taskpack::PackMode;
using bidex::taskpack::PackSpec;
using bidex::taskpack::TaskPack;
using bidex::taskpack::WarpPack;

template <class T>
using Rows = nb::ndarray<nb::numpy, const T, nb::ndim<2>, nb::c_contig>;
template <class T>
using Column = nb::ndarray<nb::numpy, const T, nb::ndim<1>, nb::c_contig>;

PackMode mode_of(const std::string& m) {
  if (m == "plain") return PackMode::kPlain;
  if (m == "multitask") return PackMode::kMultiTask;
  if (m == "meta") return PackMode::kMeta;
  throw bidex::ConfigError("pack", "mode", "'plain', 'multitask' or 'meta'", "'" + m + "'");
}

// A DLPack array over memory that the pack owns (device rows of a GPU pack, or host rows on
// Warp's CPU device): torch.from_dlpack or numpy.from_dlpack wraps it without a copy.
template <class T>
using Shared = nb::ndarray<nb::array_api, T, nb::c_contig>;

// The pack and what Python reads of it: a CPU pack (TaskPack) or a GPU pack (WarpPack).
struct PyPack {
  std::unique_ptr<TaskPack> pack;   // the CPU pack, or null
  std::unique_ptr<WarpPack> dev;    // the GPU pack, or null
  int dl_device = nb::device::cpu::value, dl_id = 0;

  // "cpu", the GPU pack's "cuda" or "cuda:N", or "warp-cpu"
  std::string device() const {
    if (pack) return "cpu";
    return dev->on_gpu() ? dev->device() : "warp-cpu";
  }
  const bidex::taskpack::Pack& base() const {
    return pack ? static_cast<const bidex::taskpack::Pack&>(*pack) : *dev;
  }
  TaskPack& cpu(const char* what) const {
    if (!pack)
      throw bidex::ConfigError("pack", what, "a CPU pack (device 'cpu')",
                               "a pack on '" + device() + "'");
    return *pack;
  }
  WarpPack& gpu(const char* what) const {
    if (!dev)
      throw bidex::ConfigError("pack", what, "a pack on the GPU backend (device 'cuda' or "
                               "'warp-cpu')", "a CPU pack");
    return *dev;
  }

  // entry g, checked (an IndexError naming the range otherwise)
  int group(int g) const {
    const int n = base().ngroups();
    if (g < 0 || g >= n)
      throw nb::index_error(("entry " + std::to_string(g) + " of a pack of " +
                             std::to_string(n) + " entries")
                                .c_str());
    return g;
  }

  // device: "cpu" (TaskPack), or the GPU backend's "cuda", "cuda:N" or "warp-cpu" (WarpPack on
  // Warp's CPU device: the GPU path's code in tests)
  PyPack(const PackSpec& spec, uint64_t seed, int threads, const std::string& device) {
    if (device == "cpu") {
      bidex::taskpack::PackOptions o;
      o.seed = seed;
      o.threads = threads;
      pack = std::make_unique<TaskPack>(spec, o);
      return;
    }
    bidex::taskpack::WarpPackOptions o;
    o.seed = seed;
    if (device == "warp-cpu") {
      o.device = "cpu";
    } else if (device == "cuda" || (device.rfind("cuda:", 0) == 0 && device.size() > 5 &&
                                    device.find_first_not_of("0123456789", 5) == std::string::npos)) {
      o.device = device;
      dl_device = nb::device::cuda::value;
      dl_id = device == "cuda" ? 0 : std::stoi(device.substr(5));
    } else {
      throw bidex::ConfigError("pack", "device", "'cpu', 'cuda', 'cuda:N' or 'warp-cpu'",
                               "'" + device + "'");
    }
    if (dl_device == nb::device::cuda::value) bidex::sim::require_gpu();
    dev = std::make_unique<WarpPack>(spec, o);
  }

  template <class T>
  Rows<T> rows(const std::vector<T>& v, int width) const {
    const size_t shape[2] = {static_cast<size_t>(pack->nslot()), static_cast<size_t>(width)};
    return Rows<T>(v.data(), 2, shape, nb::handle());
  }
  template <class T>
  Column<T> column(const std::vector<T>& v) const {
    const size_t shape[1] = {static_cast<size_t>(pack->nslot())};
    return Column<T>(v.data(), 1, shape, nb::handle());
  }
  // `rows` x `width` values at `ptr` in the GPU pack's memory (width 0: one column)
  template <class T>
  Shared<T> shared(uintptr_t ptr, int rows, int width) const {
    const size_t shape[2] = {static_cast<size_t>(rows), static_cast<size_t>(width)};
    return Shared<T>(reinterpret_cast<T*>(ptr), width ? 2 : 1, shape, nb::handle(), nullptr,
                     nb::dtype<T>(), dl_device, dl_id);
  }
};

PackSpec entries_spec(const std::string& name, const std::string& mode, const nb::list& entries) {
  PackSpec spec;
  spec.name = name;
  spec.mode = mode_of(mode);
  for (nb::handle h : entries) {
    nb::dict d = nb::cast<nb::dict>(h);
    bidex::taskpack::PackEntry e;
    e.task = nb::cast<std::string>(d["task"]);
    e.slots = nb::cast<int>(d["slots"]);
    if (d.contains("config")) e.config = nb::cast<std::string>(d["config"]);
    if (d.contains("label")) e.label = nb::cast<std::string>(d["label"]);
    if (d.contains("reward_scale")) e.reward_scale = nb::cast<double>(d["reward_scale"]);
    spec.entries.push_back(std::move(e));
  }
  return spec;
}

}  // namespace

NB_MODULE(_bidex, m) {
  m.doc() = "bidex's C++ core: tasks, specs and the CPU pack (use the bidex package, not this)";
  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const bidex::ConfigError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const bidex::Error& e) {
      PyErr_SetString(PyExc_RuntimeError, e.what());
    }
  });

  m.def("task_ids", [] {
    std::vector<std::string> ids;
    for (const auto* reg : {&bidex::tasks::task_registry(), &bidex::tasks::variant_registry()})
      for (const auto& e : *reg) ids.push_back(e.spec().id);
    return ids;
  }, "Every task id: the paper's twenty in its order, then the variants.");
  m.def("paper_task_ids", [] {
    std::vector<std::string> ids;
    for (const auto& e : bidex::tasks::task_registry()) ids.push_back(e.spec().id);
    return ids;
  }, "The paper's twenty task ids, in its order.");
  m.def("task_spec_json", [](const std::string& id, const std::string& agents) {
    const auto& spec = bidex::tasks::find_task(id).spec();
    return bidex::marl::task_spec_json(spec, bidex::marl::agents_from_arg(spec, agents)).dump();
  }, "id"_a, "agents"_a,
     "A task's spec with the agents of a split (hand, finger, or a YAML file of agents, as "
     "bidex train --agents), as the JSON text bidex info --json prints.");
  m.def("default_task_config", &bidex::tasks::default_task_config, "id"_a,
        "The path of a task's default YAML.");
  m.def("suite_ids", &bidex::taskpack::known_suites, "The suite ids (MT1 ... ML20).");
  m.attr("OBS_CLIP") = bidex::tasks::TaskEnv::kObsClip;

  m.def("gpu_backend_missing", &bidex::sim::warp_missing,
        "Empty when this build has the GPU backend (MuJoCo Warp); else what to install.");

  nb::class_<PyPack>(m, "Pack")
      .def_static("from_entries",
                  [](const std::string& name, const std::string& mode, const nb::list& entries,
                     uint64_t seed, int threads, const std::string& device) {
                    const PackSpec spec = entries_spec(name, mode, entries);
                    nb::gil_scoped_release r;  // the GPU backend takes the GIL when it needs it
                    return std::make_unique<PyPack>(spec, seed, threads, device);
                  },
                  "name"_a, "mode"_a, "entries"_a, "seed"_a, "threads"_a, "device"_a = "cpu")
      .def_static("from_suite",
                  [](const std::string& suite, const std::string& split, int slots, uint64_t seed,
                     int threads, const std::string& device) {
                    const auto s = bidex::taskpack::load_suite(suite);
                    const PackSpec spec = bidex::taskpack::suite_pack(s, split, slots);
                    nb::gil_scoped_release r;
                    return std::make_unique<PyPack>(spec, seed, threads, device);
                  },
                  "suite"_a, "split"_a, "slots"_a, "seed"_a, "threads"_a, "device"_a = "cpu")
      .def_prop_ro("device", [](const PyPack& p) { return p.device(); })
      .def_prop_ro("on_gpu", [](const PyPack& p) { return p.dev && p.dev->on_gpu(); })
      .def_prop_ro("nslot", [](const PyPack& p) { return p.base().nslot(); })
      .def_prop_ro("obs_dim", [](const PyPack& p) { return p.base().obs_dim(); })
      .def_prop_ro("act_dim", [](const PyPack& p) { return p.base().act_dim(); })
      .def_prop_ro("obs_pad", [](const PyPack& p) { return p.base().obs_pad(); })
      .def_prop_ro("threads", [](const PyPack& p) { return p.base().threads(); })
      .def_prop_ro("mode", [](const PyPack& p) { return std::string(bidex::taskpack::mode_name(p.base().spec().mode)); })
      .def_prop_ro("ngroups", [](const PyPack& p) { return p.base().ngroups(); })
      .def("group_task", [](const PyPack& p, int g) { return p.base().entry(p.group(g)).task; }, "g"_a)
      .def("group_label", [](const PyPack& p, int g) { return p.base().label(p.group(g)); }, "g"_a)
      .def("group_begin", [](const PyPack& p, int g) { return p.base().group_begin(p.group(g)); }, "g"_a)
      .def("group_slots", [](const PyPack& p, int g) { return p.base().group_slots(p.group(g)); }, "g"_a)
      .def("group_reward_scale", [](const PyPack& p, int g) { return p.base().entry(p.group(g)).reward_scale; }, "g"_a)
      .def("group_obs_keep", [](const PyPack& p, int g) { return p.base().obs_keep(p.group(g)); }, "g"_a)
      .def("group_goals", [](const PyPack& p, int g) { return p.base().entry(p.group(g)).goals; }, "g"_a,
           "Entry g's goal shifts (m), one [x, y, z] per goal of its distribution (empty: none).")
      .def("hot_column", [](const PyPack& p, int g) { return p.base().hot_column(p.group(g)); }, "g"_a)
      .def("slot_tasks", [](const PyPack& p) { return p.base().slot_tasks(); })
      .def("reset", [](PyPack& p) {
        nb::gil_scoped_release r;
        if (p.pack) p.pack->reset(); else p.dev->reset();
      })
      .def("step", [](PyPack& p, nb::ndarray<const float, nb::ndim<2>, nb::c_contig, nb::device::cpu> a) {
        TaskPack& pack = p.cpu("step(actions)");
        if (a.shape(0) != static_cast<size_t>(pack.nslot()) ||
            a.shape(1) != static_cast<size_t>(pack.act_dim()))
          throw bidex::ConfigError("step", "actions",
                                   "shape (" + std::to_string(pack.nslot()) + ", " +
                                       std::to_string(pack.act_dim()) + ")",
                                   "(" + std::to_string(a.shape(0)) + ", " +
                                       std::to_string(a.shape(1)) + ")");
        nb::gil_scoped_release r;
        pack.step(a.data());
      }, "actions"_a, "One control step of every slot; actions: float32 (nslot, act_dim), C order.")
      .def("step_device", [](PyPack& p) {
        WarpPack& pack = p.gpu("step_device()");
        nb::gil_scoped_release r;
        pack.step();
      }, "One control step of every slot of a GPU pack with the actions in view('actions'), "
         "written (and finished) by the caller; returns when every row is written.")
      .def("set_autoreset", [](PyPack& p, bool on) {
        if (p.pack) p.pack->set_autoreset(on); else p.dev->set_autoreset(on);
      }, "on"_a, "Off: a slot whose episode ends holds its final observation until reset_slots.")
      .def("reset_slots", [](PyPack& p, nb::ndarray<const uint8_t, nb::ndim<1>, nb::c_contig, nb::device::cpu> mask) {
        const int n = p.base().nslot();
        if (mask.shape(0) != static_cast<size_t>(n))
          throw bidex::ConfigError("reset_slots", "mask", "shape (" + std::to_string(n) + ",)",
                                   "(" + std::to_string(mask.shape(0)) + ",)");
        nb::gil_scoped_release r;
        if (p.pack) p.pack->reset_slots(mask.data()); else p.dev->reset_slots(mask.data());
      }, "mask"_a, "New episodes in the slots where mask (uint8, nslot, on the host) is nonzero.")
      .def_prop_ro("obs", [](const PyPack& p) { const TaskPack& t = p.cpu("obs"); return p.rows(t.obs, t.obs_dim()); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("final_obs", [](const PyPack& p) { const TaskPack& t = p.cpu("final_obs"); return p.rows(t.final_obs, t.obs_dim()); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("reward", [](const PyPack& p) { return p.column(p.cpu("reward").reward); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("terminated", [](const PyPack& p) { return p.column(p.cpu("terminated").terminated); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("truncated", [](const PyPack& p) { return p.column(p.cpu("truncated").truncated); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("success", [](const PyPack& p) { return p.column(p.cpu("success").success); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("fault", [](const PyPack& p) { return p.column(p.cpu("fault").fault); },
                   nb::rv_policy::reference_internal)
      .def("terms", [](const PyPack& p, int g) {
        const auto& env = p.cpu("terms").group(p.group(g));
        const size_t shape[2] = {static_cast<size_t>(env.nslot()), static_cast<size_t>(env.nterms())};
        return Rows<float>(env.terms.data(), 2, shape, nb::handle());
      }, "g"_a, nb::rv_policy::reference_internal,
         "Entry g's reward terms of the last step, (its slots, its terms), unscaled.")
      .def("view", [](const PyPack& p, const std::string& name) {
        const WarpPack& w = p.gpu("view");
        const int n = w.nslot();
        auto ptr = [](const float* f) { return reinterpret_cast<uintptr_t>(f); };
        if (name == "actions") return p.shared<float>(ptr(w.actions()), n, w.act_dim());
        if (name == "obs") return p.shared<float>(ptr(w.obs()), n, w.obs_dim());
        if (name == "final_obs") return p.shared<float>(ptr(w.final_obs()), n, w.obs_dim());
        if (name == "reward") return p.shared<float>(ptr(w.reward()), n, 0);
        if (name == "done") return p.shared<float>(ptr(w.done()), n, 0);
        if (name == "bootstrap") return p.shared<float>(ptr(w.bootstrap()), n, 0);
        throw bidex::ConfigError("view", "name", "actions, obs, final_obs, reward, done or bootstrap",
                                 "'" + name + "'");
      }, "name"_a, nb::rv_policy::reference_internal,
         "A GPU pack's float32 rows in place (DLPack, on the pack's device): actions (written by "
         "the caller), obs, final_obs, reward (scaled), done, bootstrap.")
      .def("entry_flags", [](const PyPack& p, int g, const std::string& name) {
        if (name != "terminated" && name != "truncated" && name != "success" && name != "faulted")
          throw bidex::ConfigError("entry_flags", "name", "terminated, truncated, success or faulted",
                                   "'" + name + "'");
        const bidex::sim::WorldArray a = p.gpu("entry_flags").group(p.group(g)).array(name);
        return p.shared<uint8_t>(a.ptr, a.rows, 0);
      }, "g"_a, "name"_a, nb::rv_policy::reference_internal,
         "Entry g's per-world flags of a GPU pack in place (DLPack, uint8): terminated, "
         "truncated, success or faulted.")
      .def("entry_terms", [](const PyPack& p, int g) {
        const bidex::sim::WorldArray a = p.gpu("entry_terms").group(p.group(g)).array("terms");
        return p.shared<float>(a.ptr, a.rows, a.width);
      }, "g"_a, nb::rv_policy::reference_internal,
         "Entry g's reward terms of a GPU pack in place (DLPack, float32 (worlds, terms), unscaled).")
      .def("render", [](PyPack& p, int slot, int width, int height) {
        TaskPack& pack = p.cpu("render");
        if (slot < 0 || slot >= pack.nslot())
          throw nb::index_error(("world " + std::to_string(slot) + " of a pack of " +
                                 std::to_string(pack.nslot()) + " worlds").c_str());
        const int g = pack.group_of(slot);
        auto& env = pack.group(g);
        const mjData* d = env.batch().data(slot - pack.group_begin(g));
        bidex::sim::RenderOptions o;
        o.width = width;
        o.height = height;
        bidex::sim::Image img;
        {
          nb::gil_scoped_release r;
          o.camera = bidex::sim::framing_camera(env.model(), d, double(width) / height);
          img = bidex::sim::render(env.model(), d, o);
        }
        auto* rgb = new std::vector<uint8_t>(std::move(img.rgb));
        nb::capsule owner(rgb, [](void* v) noexcept { delete static_cast<std::vector<uint8_t>*>(v); });
        const size_t shape[3] = {static_cast<size_t>(img.height), static_cast<size_t>(img.width), 3};
        return nb::ndarray<nb::numpy, uint8_t, nb::ndim<3>>(rgb->data(), 3, shape, owner);
      }, "slot"_a, "width"_a, "height"_a,
         "One world's picture, (height, width, 3) uint8, from a camera that frames the scene "
         "(the headless renderer of sim/render.h, as bidex render uses).")
      .def("set_goal_shifts", [](PyPack& p, int g, const std::vector<int>& local,
                                 const std::vector<double>& shifts) {
        const int gg = p.group(g);
        if (p.pack) p.pack->set_goal_shifts(gg, local, shifts); else p.dev->set_goal_shifts(gg, local, shifts);
      }, "g"_a, "local"_a, "shifts"_a);
}
