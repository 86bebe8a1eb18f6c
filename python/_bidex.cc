// bidex._bidex: the Python module over the C++ core's CPU pack (taskpack::TaskPack), the same
// env API that bidex's own learners step (python/README.md), and the multi-agent splits of
// marl/split.h. It links sim, tasks, taskpack and marl_split, never LibTorch. The pack's result
// rows are handed to numpy without a copy; step() releases the GIL while the pack steps every
// slot in its parallel loop.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/unique_ptr.h>
#include <nanobind/stl/vector.h>

#include <memory>
#include <string>
#include <vector>

#include "core/error.h"
#include "marl/spec_json.h"
#include "sim/render.h"
#include "taskpack/pack.h"
#include "taskpack/suite.h"
#include "tasks/registry.h"

namespace nb = nanobind;
using namespace nb::literals;

namespace {

using bidex::taskpack::PackMode;
using bidex::taskpack::PackSpec;
using bidex::taskpack::TaskPack;

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

// The pack and what Python reads of it.
struct PyPack {
  std::unique_ptr<TaskPack> pack;

  // entry g, checked (an IndexError naming the range otherwise)
  int group(int g) const {
    if (g < 0 || g >= pack->ngroups())
      throw nb::index_error(("entry " + std::to_string(g) + " of a pack of " +
                             std::to_string(pack->ngroups()) + " entries")
                                .c_str());
    return g;
  }

  PyPack(const PackSpec& spec, uint64_t seed, int threads) {
    bidex::taskpack::PackOptions o;
    o.seed = seed;
    o.threads = threads;
    pack = std::make_unique<TaskPack>(spec, o);
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

  nb::class_<PyPack>(m, "Pack")
      .def_static("from_entries",
                  [](const std::string& name, const std::string& mode, const nb::list& entries,
                     uint64_t seed, int threads) {
                    return std::make_unique<PyPack>(entries_spec(name, mode, entries), seed, threads);
                  },
                  "name"_a, "mode"_a, "entries"_a, "seed"_a, "threads"_a)
      .def_static("from_suite",
                  [](const std::string& suite, const std::string& split, int slots, uint64_t seed,
                     int threads) {
                    const auto s = bidex::taskpack::load_suite(suite);
                    return std::make_unique<PyPack>(bidex::taskpack::suite_pack(s, split, slots),
                                                    seed, threads);
                  },
                  "suite"_a, "split"_a, "slots"_a, "seed"_a, "threads"_a)
      .def_prop_ro("nslot", [](const PyPack& p) { return p.pack->nslot(); })
      .def_prop_ro("obs_dim", [](const PyPack& p) { return p.pack->obs_dim(); })
      .def_prop_ro("act_dim", [](const PyPack& p) { return p.pack->act_dim(); })
      .def_prop_ro("obs_pad", [](const PyPack& p) { return p.pack->obs_pad(); })
      .def_prop_ro("threads", [](const PyPack& p) { return p.pack->threads(); })
      .def_prop_ro("mode", [](const PyPack& p) { return std::string(bidex::taskpack::mode_name(p.pack->spec().mode)); })
      .def_prop_ro("ngroups", [](const PyPack& p) { return p.pack->ngroups(); })
      .def("group_task", [](const PyPack& p, int g) { return p.pack->entry(p.group(g)).task; }, "g"_a)
      .def("group_label", [](const PyPack& p, int g) { return p.pack->label(p.group(g)); }, "g"_a)
      .def("group_begin", [](const PyPack& p, int g) { return p.pack->group_begin(p.group(g)); }, "g"_a)
      .def("group_slots", [](const PyPack& p, int g) { return p.pack->group_slots(p.group(g)); }, "g"_a)
      .def("group_reward_scale", [](const PyPack& p, int g) { return p.pack->entry(p.group(g)).reward_scale; }, "g"_a)
      .def("group_obs_keep", [](const PyPack& p, int g) { return p.pack->obs_keep(p.group(g)); }, "g"_a)
      .def("hot_column", [](const PyPack& p, int g) { return p.pack->hot_column(p.group(g)); }, "g"_a)
      .def("slot_tasks", [](const PyPack& p) { return p.pack->slot_tasks(); })
      .def("reset", [](PyPack& p) {
        nb::gil_scoped_release r;
        p.pack->reset();
      })
      .def("step", [](PyPack& p, nb::ndarray<const float, nb::ndim<2>, nb::c_contig, nb::device::cpu> a) {
        if (a.shape(0) != static_cast<size_t>(p.pack->nslot()) ||
            a.shape(1) != static_cast<size_t>(p.pack->act_dim()))
          throw bidex::ConfigError("step", "actions",
                                   "shape (" + std::to_string(p.pack->nslot()) + ", " +
                                       std::to_string(p.pack->act_dim()) + ")",
                                   "(" + std::to_string(a.shape(0)) + ", " +
                                       std::to_string(a.shape(1)) + ")");
        nb::gil_scoped_release r;
        p.pack->step(a.data());
      }, "actions"_a, "One control step of every slot; actions: float32 (nslot, act_dim), C order.")
      .def_prop_ro("obs", [](const PyPack& p) { return p.rows(p.pack->obs, p.pack->obs_dim()); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("final_obs", [](const PyPack& p) { return p.rows(p.pack->final_obs, p.pack->obs_dim()); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("reward", [](const PyPack& p) { return p.column(p.pack->reward); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("terminated", [](const PyPack& p) { return p.column(p.pack->terminated); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("truncated", [](const PyPack& p) { return p.column(p.pack->truncated); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("success", [](const PyPack& p) { return p.column(p.pack->success); },
                   nb::rv_policy::reference_internal)
      .def_prop_ro("fault", [](const PyPack& p) { return p.column(p.pack->fault); },
                   nb::rv_policy::reference_internal)
      .def("terms", [](const PyPack& p, int g) {
        const auto& env = p.pack->group(p.group(g));
        const size_t shape[2] = {static_cast<size_t>(env.nslot()), static_cast<size_t>(env.nterms())};
        return Rows<float>(env.terms.data(), 2, shape, nb::handle());
      }, "g"_a, nb::rv_policy::reference_internal,
         "Entry g's reward terms of the last step, (its slots, its terms), unscaled.")
      .def("render", [](PyPack& p, int slot, int width, int height) {
        if (slot < 0 || slot >= p.pack->nslot())
          throw nb::index_error(("world " + std::to_string(slot) + " of a pack of " +
                                 std::to_string(p.pack->nslot()) + " worlds").c_str());
        const int g = p.pack->group_of(slot);
        auto& env = p.pack->group(g);
        const mjData* d = env.batch().data(slot - p.pack->group_begin(g));
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
        p.pack->set_goal_shifts(p.group(g), local, shifts);
      }, "g"_a, "local"_a, "shifts"_a);
}
