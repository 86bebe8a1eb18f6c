// grasp_and_place's stage bodies (tasks/README.md): GraspAndPlaceProgram and the four stages
// over one world's rows, for host and device. GraspAndPlace (grasp_and_place.h) builds the
// program in bind().
#pragma once

#include <type_traits>

#include "core/hd.h"
#include "core/rng.h"
#include "sim/state_view.h"
#include "tasks/hand_body.h"
#include "tasks/math.h"
#include "tasks/object_body.h"
#include "tasks/slot_state.h"

namespace bidex::tasks {

struct GraspAndPlaceProgram {
  HandRig hands[2];  // right, left
  int bucket = -1, object = -1, bucket_tree = -1;
  // reward: exp(-k sum_R(bucket)) + exp(-k sum_L(object)) + place_scale exp(-k |bucket - object|)
  double decay = 0, place_scale = 0, success_tolerance = 0;
  double max_tip_distance = 0;  // 0: off
  int t_right = -1, t_left = -1, t_place = -1;
};
static_assert(std::is_trivially_copyable_v<GraspAndPlaceProgram>,
              "copied to the device as bytes");

// New episode: bucket and object at their start poses (the simulation's reset).
template <class Real>
BIDEX_HD void grasp_and_place_reset(const GraspAndPlaceProgram&, const sim::ResetRows<Real>&,
                                    SlotState&, SlotRng&) {}

template <class Real>
BIDEX_HD void grasp_and_place_apply_actions(const GraspAndPlaceProgram& p, const float* a,
                                            const sim::WorldRows<Real>& w) {
  apply_two_hand_actions(p.hands, a, w);
}

// The reward terms, success (object near the bucket); ends when a hand strays.
template <class Real>
BIDEX_HD bool grasp_and_place_evaluate(const GraspAndPlaceProgram& p,
                                       const sim::WorldRows<Real>& w, SlotState& st, SlotRng&,
                                       Real* terms) {
  const Real* k = w.xpos + 3 * p.bucket;
  const Real* c = w.xpos + 3 * p.object;
  const Real d_right = tip_distance_sum(p.hands[0], w, k);
  const Real d_left = tip_distance_sum(p.hands[1], w, c);
  const Real d = math::dist3(k, c);
  const Real decay = Real(p.decay);
  terms[p.t_right] = math::exp(-decay * d_right);
  terms[p.t_left] = math::exp(-decay * d_left);
  terms[p.t_place] = Real(p.place_scale) * math::exp(-decay * d);
  if (d < Real(p.success_tolerance)) st.success = true;
  const Real far = Real(p.max_tip_distance);
  return p.max_tip_distance > 0 && (d_left >= far || d_right >= far);
}

// Both hand blocks, the bucket's object block, the bucket's and the object's poses.
template <class Real>
BIDEX_HD void grasp_and_place_observe(const GraspAndPlaceProgram& p,
                                      const sim::WorldRows<Real>& w, const SlotState& st,
                                      float* obs) {
  float* o = observe_two_hands(p.hands, w, st.action.data(), obs);
  observe_object(w, p.bucket, p.bucket_tree, o);
  math::put_vec3(o + 13, w.xpos + 3 * p.bucket);
  math::put_quat_xyzw(o + 16, w.xquat + 4 * p.bucket);
  math::put_vec3(o + 20, w.xpos + 3 * p.object);
  math::put_quat_xyzw(o + 23, w.xquat + 4 * p.object);
}

}  // namespace bidex::tasks
