// Running a command (the real bidex binary, a MuJoCo tool) as a user would: its exit status and
// its stdout and stderr together. No std::filesystem and no LibTorch, so every test binary can
// include it.
#pragma once

#include <cstdio>
#include <string>

#include <sys/wait.h>

#include <catch2/catch.hpp>

namespace bidex::test {

struct CommandResult {
  int rc = -1;
  std::string out;  // stdout and stderr together
};

// Runs a shell command line.
inline CommandResult run_command(const std::string& cmd) {
  CommandResult r;
  std::FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  REQUIRE(p != nullptr);
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int status = ::pclose(p);
  r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

#ifdef BIDEX_BINARY
// Runs the bidex binary of this build with `args`.
inline CommandResult bidex_run(const std::string& args) {
  // built with append: GCC 12 -O3 warns (-Werror=restrict) on "'" + std::string(...)
  std::string cmd = "'";
  cmd.append(BIDEX_BINARY).append("' ").append(args);
  return run_command(cmd);
}
#endif

}  // namespace bidex::test
