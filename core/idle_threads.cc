#include "core/idle_threads.h"

#include <cstring>

#include <unistd.h>

namespace bidex {
namespace {

bool has_variable(char** envp, const char* name) {
  const size_t n = std::strlen(name);
  for (char** e = envp; e && *e; ++e)
    if (std::strncmp(*e, name, n) == 0 && (*e)[n] == '=') return true;
  return false;
}

}  // namespace

void rest_idle_threads(int, char** argv, char** envp) {
  exec_with_idle_threads("/proc/self/exe", argv, envp);
}

void exec_with_idle_threads(const char* exe, char** argv, char** envp) {
  // Before libc's initialiser: no setenv, no allocation. The new environment is the old one and
  // the variables it lacks.
  constexpr size_t kMax = 4096;
  static char* env[kMax];
  static char text[kIdleThreadSettingCount][64];  // "NAME=value" of the settings' sizes
  size_t n = 0;
  for (char** e = envp; e && *e; ++e) {
    if (n + kIdleThreadSettingCount + 1 >= kMax) return;  // too many to copy: run on as we are
    env[n++] = *e;
  }
  bool added = false;
  for (size_t i = 0; i < kIdleThreadSettingCount; ++i) {
    const auto& s = kIdleThreadSettings[i];
    if (has_variable(envp, s.name)) continue;
    text[i][0] = '\0';
    std::strcat(std::strcat(std::strcat(text[i], s.name), "="), s.value);
    env[n++] = text[i];
    added = true;
  }
  env[n] = nullptr;
  if (added) ::execve(exe, argv, env);  // returns only on failure: run on
}

}  // namespace bidex
