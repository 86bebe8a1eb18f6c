#include "tasks/task.h"

#include <cstring>

#include <mujoco/mujoco.h>

namespace bidex::tasks {

sim::WorldRows<double> world_rows(const sim::SlotView& v) {
  sim::WorldRows<double> w;
  w.qpos = v.qpos;
  w.qvel = v.qvel;
  w.qfrc_actuator = v.qfrc_actuator;
  w.qfrc_constraint = v.qfrc_constraint;
  w.sensordata = v.sensordata;
  w.xpos = v.xpos;
  w.xquat = v.xquat;
  w.cvel = v.cvel;
  w.subtree_com = v.subtree_com;
  w.ctrl = v.ctrl;
  w.base_wrench = v.base_wrench;
  return w;
}

sim::WorldRows<double> world_rows(const TaskSlot& t) {
  sim::WorldRows<double> w = world_rows(t.state);
  if (t.data) {
    w.mocap_pos = t.data->mocap_pos;
    w.mocap_quat = t.data->mocap_quat;
  }
  return w;
}

sim::ResetRows<double> reset_rows(TaskSlot& t) {
  sim::ResetRows<double> r;
  r.qpos = t.data->qpos;
  r.qvel = t.data->qvel;
  r.ctrl = t.state.ctrl;
  r.mocap_pos = t.data->mocap_pos;
  r.mocap_quat = t.data->mocap_quat;
  return r;
}

void end_reset(TaskSlot& t) {
  std::memcpy(t.data->ctrl, t.state.ctrl, sizeof(double) * t.model->nu());
}

}  // namespace bidex::tasks
