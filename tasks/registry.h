// Every task of bidex, registered in one place (registry.cc), in the paper's order.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tasks/task.h"

namespace bidex::tasks {

struct TaskEntry {
  const TaskSpec& (*spec)();
  std::unique_ptr<Task> (*make)(const std::string& config_file);
};

// The paper's tasks, in the paper's order.
const std::vector<TaskEntry>& task_registry();
// Variants of them (TaskSpec::variant_of): reduced tasks for learning tests in CI, and the
// free-base hand_over of the MT4/ML4 suites.
const std::vector<TaskEntry>& variant_registry();
// The entry of a task or variant id; throws ConfigError listing the known ids.
const TaskEntry& find_task(const std::string& id);
// The default YAML of a task: tasks/<id>/<id>.yaml under the data folder.
std::string default_task_config(const std::string& id);
// A task configured from `config_file` (empty: its default YAML).
std::unique_ptr<Task> make_task(const std::string& id, const std::string& config_file = "");

// Each task folder defines its spec and factory (declared here, defined there).
#define BIDEX_TASK(id)                   \
  const TaskSpec& id##_spec();           \
  std::unique_ptr<Task> make_##id(const std::string& config_file);
BIDEX_TASK(hand_over)
BIDEX_TASK(catch_underarm)
BIDEX_TASK(catch_over2underarm)
BIDEX_TASK(catch_abreast)
BIDEX_TASK(two_catch_underarm)
BIDEX_TASK(lift_underarm)
BIDEX_TASK(door_open_outward)
BIDEX_TASK(door_close_inward)
BIDEX_TASK(door_open_inward)
BIDEX_TASK(door_close_outward)
BIDEX_TASK(bottle_cap)
BIDEX_TASK(push_block)
BIDEX_TASK(swing_cup)
BIDEX_TASK(scissors)
BIDEX_TASK(re_orientation)
BIDEX_TASK(pen)
BIDEX_TASK(switch)
BIDEX_TASK(block_stack)
BIDEX_TASK(pour_water)
BIDEX_TASK(grasp_and_place)
BIDEX_TASK(catch_underarm_raise)
BIDEX_TASK(hand_over_free)
#undef BIDEX_TASK

}  // namespace bidex::tasks
