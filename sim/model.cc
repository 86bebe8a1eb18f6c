#include "sim/model.h"

#include <mujoco/mujoco.h>

#include "core/error.h"

namespace bidex::sim {

mjModel* compile_mjcf(const std::string& mjcf, const std::string& name) {
  // loaded from memory through a virtual file system holding one file, the text
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  const char* fname = "scene.xml";
  if (mj_addBufferVFS(&vfs, fname, mjcf.data(), static_cast<int>(mjcf.size())) != 0) {
    mj_deleteVFS(&vfs);
    throw ModelError(name + ": cannot create an in-memory file for the model");
  }
  char err[1024] = "";
  mjModel* m = mj_loadXML(fname, &vfs, err, sizeof err);
  mj_deleteVFS(&vfs);
  if (!m) throw ModelError(name + ": MuJoCo could not compile the model: " + err);
  return m;
}

SimModel::SimModel(mjModel* m, std::string mjcf, PhysicsOptions physics,
                   std::vector<HandIndex> hands, std::vector<ObjectIndex> objects)
    : m_(m),
      mjcf_(std::move(mjcf)),
      physics_(std::move(physics)),
      hands_(std::move(hands)),
      objects_(std::move(objects)) {
  // memory of one world, measured on a real mjData
  mjData* d = mj_makeData(m_);
  data_bytes_ = sizeof(mjData) + static_cast<size_t>(d->nbuffer) + static_cast<size_t>(d->narena);
  mj_deleteData(d);
}

SimModel::~SimModel() {
  if (m_) mj_deleteModel(m_);
}

SimModel::SimModel(SimModel&& o) noexcept
    : m_(o.m_),
      mjcf_(std::move(o.mjcf_)),
      physics_(std::move(o.physics_)),
      hands_(std::move(o.hands_)),
      objects_(std::move(o.objects_)),
      data_bytes_(o.data_bytes_) {
  o.m_ = nullptr;
}

SimModel& SimModel::operator=(SimModel&& o) noexcept {
  if (this != &o) {
    if (m_) mj_deleteModel(m_);
    m_ = o.m_;
    o.m_ = nullptr;
    mjcf_ = std::move(o.mjcf_);
    physics_ = std::move(o.physics_);
    hands_ = std::move(o.hands_);
    objects_ = std::move(o.objects_);
    data_bytes_ = o.data_bytes_;
  }
  return *this;
}

const HandIndex* SimModel::hand(Side s) const {
  for (auto& h : hands_)
    if (h.side == s) return &h;
  return nullptr;
}

const ObjectIndex* SimModel::object(const std::string& name) const {
  for (auto& o : objects_)
    if (o.name == name) return &o;
  return nullptr;
}

int SimModel::nq() const { return m_->nq; }
int SimModel::nv() const { return m_->nv; }
int SimModel::nu() const { return m_->nu; }
int SimModel::nbody() const { return m_->nbody; }
int SimModel::nsensordata() const { return m_->nsensordata; }

}  // namespace bidex::sim
