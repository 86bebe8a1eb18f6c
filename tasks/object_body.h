// The object and goal blocks of an observation, over one world's rows (sim/state_view.h), for
// host and device (core/hd.h). Host callers with a SlotView use tasks/objects.h.
#pragma once

#include "core/hd.h"
#include "sim/state_view.h"
#include "tasks/hand_body.h"
#include "tasks/math.h"

namespace bidex::tasks {

// The object block (13 values): position 3, orientation (x, y, z, w) 4, linear velocity 3,
// angular velocity x 0.2 3, of a body whose tree's root body is `root_tree`.
template <class Real>
BIDEX_HD void observe_object(const sim::WorldRows<Real>& w, int body, int root_tree, float* out) {
  Real lin[3], ang[3];
  body_velocity(w, body, root_tree, lin, ang);
  float* o = out;
  for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(w.xpos[3 * body + k]);
  math::put_quat_xyzw(o, w.xquat + 4 * body);
  o += 4;
  for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(lin[k]);
  for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(Real(0.2) * ang[k]);
}

// The goal block (11 values): goal position 3, goal orientation 4, then the quaternion difference
// object * conj(goal) 4 (orientations written (x, y, z, w)); `goal` is position then (w, x, y, z).
template <class Goal, class Real>
BIDEX_HD void observe_goal(const Goal* goal, const Real* object_quat, float* out) {
  for (int k = 0; k < 3; ++k) out[k] = static_cast<float>(goal[k]);
  math::put_quat_xyzw(out + 3, goal + 3);
  Real gq[4], gc[4], diff[4];
  for (int k = 0; k < 4; ++k) gq[k] = static_cast<Real>(goal[3 + k]);
  math::quat_conj(gc, gq);
  math::mul_quat(diff, object_quat, gc);
  math::put_quat_xyzw(out + 7, diff);
}

}  // namespace bidex::tasks
