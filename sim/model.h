// SimModel: one compiled scene (MuJoCo's mjModel) plus the index tables that tasks use to find
// hands, joints, fingertips and objects. Constant once built; shared by every slot of a batch.
// MuJoCo's headers stay out of this file: include <mujoco/mujoco.h> where mj() is dereferenced.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "sim/hand_spec.h"
#include "sim/physics.h"

struct mjModel_;
typedef struct mjModel_ mjModel;

namespace bidex::sim {

// Where one hand lives inside the compiled model.
struct HandIndex {
  Side side = Side::kRight;
  std::string prefix;            // name prefix of its bodies, joints, ... ("rh_", "lh_")
  bool free_base = false;        // has the 6-DoF base
  int root_body = -1;            // the forearm: base forces act here
  std::vector<int> bodies;       // every body of the hand
  std::vector<std::string> joint_names;  // unprefixed, tree order (24 for the Shadow Hand)
  std::vector<int> joints;       // joint ids, tree order
  std::vector<int> qpos_adr;     // per joint
  std::vector<int> dof_adr;      // per joint
  std::vector<int> actuators;    // position actuators, tree order (20)
  std::vector<int> actuated;     // index into `joints` of each actuator's joint
  std::vector<int> tip_sites;    // force/torque sites (fingertips), tree order
  std::vector<int> tip_bodies;   // body of each tip site
  std::vector<int> tip_force_adr, tip_torque_adr;  // sensordata address per tip (3 values each)
  int base_qpos_adr = -1;        // 3 slides (x, y, z world axes) then a ball joint: 7 values
  int base_dof_adr = -1;         // 6 values
};

// A free or fixed object placed by the scene builder.
struct ObjectIndex {
  std::string name;
  int body = -1;
  int qpos_adr = -1;  // free joint: 7 values (pos, quat), -1 when fixed
  int dof_adr = -1;   // free joint: 6 values
  int mocap = -1;     // goal markers: index into mjData::mocap_pos (3 per) and mocap_quat (4 per)
};

class SimModel {
 public:
  SimModel(mjModel* m, std::string mjcf, PhysicsOptions physics, std::vector<HandIndex> hands,
           std::vector<ObjectIndex> objects);
  ~SimModel();
  SimModel(SimModel&&) noexcept;
  SimModel& operator=(SimModel&&) noexcept;
  SimModel(const SimModel&) = delete;
  SimModel& operator=(const SimModel&) = delete;

  const mjModel* mj() const { return m_; }
  const std::string& mjcf() const { return mjcf_; }
  const PhysicsOptions& physics() const { return physics_; }
  const std::vector<HandIndex>& hands() const { return hands_; }
  const std::vector<ObjectIndex>& objects() const { return objects_; }
  const HandIndex* hand(Side s) const;
  const ObjectIndex* object(const std::string& name) const;

  // sizes of one world
  int nq() const;
  int nv() const;
  int nu() const;
  int nbody() const;
  int nsensordata() const;
  int nwrench() const { return static_cast<int>(hands_.size()) * 6; }

  // Bytes of one mjData of this model (struct, buffer and arena), as allocated by MuJoCo.
  size_t data_bytes() const { return data_bytes_; }

 private:
  mjModel* m_ = nullptr;
  std::string mjcf_;
  PhysicsOptions physics_;
  std::vector<HandIndex> hands_;
  std::vector<ObjectIndex> objects_;
  size_t data_bytes_ = 0;
};

// Compiles MJCF text with MuJoCo, from memory; throws ModelError with MuJoCo's message.
// `name` labels the text in messages.
mjModel* compile_mjcf(const std::string& mjcf, const std::string& name);

}  // namespace bidex::sim
