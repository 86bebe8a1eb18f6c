// A task whose four stages are a family's stage bodies (tasks/README.md): the calls from the
// CPU path's stage methods into the bodies, written once. A family names its bodies with
// BIDEX_STAGE_BODIES (a struct the GPU path's per-world functions call too, tasks/world_step.h)
// and derives its task class from BodyTask<Base, NameBodies>; its bind() fills `prog_`.
#pragma once

#include "core/hd.h"
#include "core/rng.h"
#include "sim/state_view.h"
#include "tasks/slot_state.h"
#include "tasks/task.h"

namespace bidex::tasks {

// `name`Bodies: the family's <prefix>reset, <prefix>apply_actions, <prefix>evaluate and
// <prefix>observe behind four fixed names, for any row scalar.
#define BIDEX_STAGE_BODIES(name, Program_, prefix)                                             \
  struct name##Bodies {                                                                       \
    using Program = Program_;                                                                 \
    template <class R>                                                                        \
    BIDEX_HD static void reset(const Program& p, const sim::ResetRows<R>& r, SlotState& st,   \
                               SlotRng& rng) {                                                \
      prefix##reset(p, r, st, rng);                                                           \
    }                                                                                         \
    template <class R>                                                                        \
    BIDEX_HD static void apply(const Program& p, const float* a, const sim::WorldRows<R>& w) { \
      prefix##apply_actions(p, a, w);                                                         \
    }                                                                                         \
    template <class R>                                                                        \
    BIDEX_HD static bool evaluate(const Program& p, const sim::WorldRows<R>& w, SlotState& st, \
                                  SlotRng& rng, R* terms) {                                   \
      return prefix##evaluate(p, w, st, rng, terms);                                          \
    }                                                                                         \
    template <class R>                                                                        \
    BIDEX_HD static void observe(const Program& p, const sim::WorldRows<R>& w,                \
                                 const SlotState& st, float* o) {                             \
      prefix##observe(p, w, st, o);                                                           \
    }                                                                                         \
  }

template <class Base, class B>
class BodyTask : public Base {
 public:
  using Bodies = B;
  using Program = typename B::Program;
  using Base::Base;

  void reset(TaskSlot& t) const override {
    B::reset(prog_, reset_rows(t), *t.task, *t.rng);
    end_reset(t);
  }
  void apply_actions(const float* a, TaskSlot& t) const override {
    B::apply(prog_, a, world_rows(t));
  }
  bool evaluate(TaskSlot& t, double* terms) const override {
    return B::evaluate(prog_, world_rows(t), *t.task, *t.rng, terms);
  }
  void observe(const TaskSlot& t, float* obs) const override {
    B::observe(prog_, world_rows(t), *t.task, obs);
  }
  // What the stage bodies need, complete after bind().
  const Program& program() const { return prog_; }

 protected:
  Program prog_;
};

}  // namespace bidex::tasks
