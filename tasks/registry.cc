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
      {swing_cup_spec, make_swing_cup},
      {scissors_spec, make_scissors},
      {pen_spec, make_pen},
      {switch_spec, make_switch},
      {pour_water_spec, make_pour_water},
  };
  return all;
}

const TaskEntry& find_task(const std::string& id) {
  std::string known;
  for (auto& e : task_registry()) {
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
