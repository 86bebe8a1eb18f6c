#include "registry/task_file.h"

#include <climits>
#include <cstdlib>

#include "core/error.h"
#include "core/yaml.h"
#include "registry/sql.h"

namespace bidex::registry {

namespace {

const char* const kFacts[] = {"names", "version", "age", "difficulty", "skill", "obs_dim",
                              "act_dim", nullptr};

std::string nonempty(const YamlView& v, const std::string& key) {
  const YamlView c = v.child(key);
  std::string s = c.as<std::string>();
  if (s.empty()) c.fail("a non-empty string", "an empty string");
  return s;
}

int at_least(const YamlView& v, const std::string& key, int min, const std::string& expected) {
  const YamlView c = v.child(key);
  const int x = c.as<int>();
  if (x < min) c.fail(expected, c.repr());
  return x;
}

bool id_char(char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_'; }

std::string absolute(const std::string& file) {
  char buf[PATH_MAX];
  if (::realpath(file.c_str(), buf)) return buf;
  return file;
}

}  // namespace

const char* const* task_facts() { return kFacts; }

TaskRecord load_task_file(const std::string& file) {
  const YamlView root = YamlView::load_file(file);
  root.expect_map();
  root.allow_keys({"id", "version", "paper_name", "original_name", "age", "difficulty", "skill",
                   "obs_dim", "act_dim", "sources"});
  TaskRecord t;
  {
    const YamlView c = root.child("id");
    t.id = c.as<std::string>();
    bool ok = !t.id.empty() && t.id[0] >= 'a' && t.id[0] <= 'z';
    for (char ch : t.id) ok = ok && id_char(ch);
    if (!ok) c.fail("a task id: a lower-case letter, then lower-case letters, digits or _", c.repr());
  }
  t.version = at_least(root, "version", 1, "an integer >= 1");
  t.paper_name = nonempty(root, "paper_name");
  if (auto c = root.maybe("original_name")) t.original_name = c->as<std::string>();

  const YamlView age = root.child("age");
  age.expect_map();
  age.allow_keys({"min", "max", "text"});
  t.age_min = at_least(age, "min", 0, "a number of months >= 0");
  t.age_max = at_least(age, "max", t.age_min,
                       sql::cat("a number of months >= age.min (", std::to_string(t.age_min), ")"));
  t.age_text = nonempty(age, "text");

  {
    const YamlView c = root.child("difficulty");
    t.difficulty = c.as<std::string>();
    if (t.difficulty != "easy" && t.difficulty != "medium" && t.difficulty != "hard")
      c.fail("easy, medium or hard", c.repr());
  }
  t.skill = nonempty(root, "skill");
  t.obs_dim = at_least(root, "obs_dim", 1, "an observation width >= 1");
  t.act_dim = at_least(root, "act_dim", 1, "an action width >= 1");

  const YamlView sources = root.child("sources");
  sources.allow_keys({"names", "version", "age", "difficulty", "skill", "obs_dim", "act_dim"});
  for (auto& fact : sources.keys()) t.sources[fact] = nonempty(sources, fact);
  for (const char* required : {"age", "difficulty"})
    if (!t.sources.count(required)) sources.child(required);  // names the missing key
  t.origin = absolute(file);
  return t;
}

}  // namespace bidex::registry
