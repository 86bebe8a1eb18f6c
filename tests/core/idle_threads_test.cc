// core/idle_threads.h: the environment a program is started again with, seen by /usr/bin/env.
#include "core/idle_threads.h"

#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>

namespace {

struct Started {
  int rc = -1;          // the child's exit status: 42 when exec_with_idle_threads returned
  std::string out;      // what /usr/bin/env printed
};

// Calls bidex::exec_with_idle_threads("/usr/bin/env", ...) with `vars` in a child process.
Started start_env_with(std::vector<std::string> vars) {
  int fds[2];
  REQUIRE(::pipe(fds) == 0);
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    ::dup2(fds[1], 1);
    ::close(fds[0]);
    std::vector<char*> envp;
    for (auto& v : vars) envp.push_back(v.data());
    envp.push_back(nullptr);
    char name[] = "env";
    char* argv[] = {name, nullptr};
    bidex::exec_with_idle_threads("/usr/bin/env", argv, envp.data());
    ::_exit(42);
  }
  ::close(fds[1]);
  Started s;
  char buf[4096];
  ssize_t n;
  while ((n = ::read(fds[0], buf, sizeof buf)) > 0) s.out.append(buf, static_cast<size_t>(n));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  s.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return s;
}

}  // namespace

TEST_CASE("a program starts again with the idle-thread settings it lacks, keeping the user's",
          "[core]") {
  // none set: both added, the rest kept
  auto a = start_env_with({"HOME=/nowhere", "OMP_WAIT_POLICY_X=1"});
  CHECK(a.rc == 0);
  CHECK(a.out == "HOME=/nowhere\nOMP_WAIT_POLICY_X=1\nOMP_WAIT_POLICY=passive\n"
                 "OPENBLAS_THREAD_TIMEOUT=4\n");
  // a value the user set wins; only the other is added
  auto b = start_env_with({"OMP_WAIT_POLICY=active"});
  CHECK(b.rc == 0);
  CHECK(b.out == "OMP_WAIT_POLICY=active\nOPENBLAS_THREAD_TIMEOUT=4\n");
  // every one set: no second start
  auto c = start_env_with({"OPENBLAS_THREAD_TIMEOUT=30", "OMP_WAIT_POLICY=active"});
  CHECK(c.rc == 42);
  CHECK(c.out.empty());
  // ctest's environment for every test (CMakeLists.txt, BIDEX_IDLE_THREADS) holds these settings
  std::string listed;
  for (const auto& s : bidex::kIdleThreadSettings)
    listed += std::string(listed.empty() ? "" : " ") + s.name + "=" + s.value;
  CHECK(listed == BIDEX_IDLE_THREADS);
}
