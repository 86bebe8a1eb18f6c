#include "tasks/registry.h"

#include "core/error.h"
#include "sim/hand_spec.h"

namespace bidex::tasks {

const std::vector<TaskEntry>& task_registry() {
  static const std::vector<TaskEntry> all = {
      {hand_over_spec, make_hand_over},
      {catch_underarm_spec, make_catch_underarm},
      {catch_over2underarm_spec, make_catch_over2underarm},
      {catch_abreast_spec, make_catch_abreast},
      {two_catch_underarm_spec, make_two_catch_underarm},
      {lift_underarm_spec, make_lift_underarm},
      {door_open_outward_spec, make_door_open_outward},
      {door_close_inward_spec, make_door_close_inward},
      {door_open_inward_spec, make_door_open_inward},
      {door_close_outward_spec, make_door_close_outward},
      {bottle_cap_spec, make_bottle_cap},
      {push_block_spec, make_push_block},
      {swing_cup_spec, make_swing_cup},
      {scissors_spec, make_scissors},
      {re_orientation_spec, make_re_orientation},
      {pen_spec, make_pen},
      {switch_spec, make_switch},
      {block_stack_spec, make_block_stack},
      {pour_water_spec, make_pour_water},
      {grasp_and_place_spec, make_grasp_and_place},
  };
  return all;
}

const std::vector<TaskEntry>& variant_registry() {
  static const std::vector<TaskEntry> all = {
      {catch_underarm_raise_spec, make_catch_underarm_raise},
      {hand_over_free_spec, make_hand_over_free},
  };
  return all;
}

const TaskEntry& find_task(const std::string& id) {
  std::string known;
  for (auto* list : {&task_registry(), &variant_registry()})
    for (auto& e : *list) {
      if (e.spec().id == id) return e;
      known += (known.empty() ? "" : ", ") + e.spec().id;
    }
  throw ConfigError("", "task", "a known task id (" + known + ")", "'" + id + "'");
}

std::string default_task_config(const std::string& id) {
  return sim::data_dir() + "/tasks/" + id + "/" + id + ".yaml";
}

std::unique_ptr<Task> make_task(const std::string& id, const std::string& config_file) {
  const TaskEntry& e = find_task(id);
  return e.make(config_file.empty() ? default_task_config(id) : config_file);
}

}  // namespace bidex::tasks
