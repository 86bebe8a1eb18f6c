// A task description file for `bidex registry add-task` (registry/README.md, example:
// configs/registry/example_task.yaml), read strictly: unknown keys, missing fields, wrong types
// and impossible values are ConfigErrors naming the file, the key, what was expected and what
// was found.
#pragma once

#include <string>

#include "registry/registry.h"

namespace bidex::registry {

// The facts a source may be given for (TaskRecord::sources keys).
const char* const* task_facts();  // null-terminated: names, version, age, difficulty, ...

// Reads a task description; origin is the file's absolute path.
TaskRecord load_task_file(const std::string& file);

}  // namespace bidex::registry
