// The test runner. bidex commands started by tests record their runs in a registry of their own
// ($BIDEX_REGISTRY, a fresh temporary file per test process, removed at exit), never in the
// working directory's runs/registry.sqlite.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>

#include <cstdlib>
#include <string>

#include <unistd.h>

#include "core/idle_threads.h"

BIDEX_REST_IDLE_THREADS_BEFORE_LIBRARIES;  // as the bidex command

int main(int argc, char** argv) {
  std::string dir;
  if (!std::getenv("BIDEX_REGISTRY")) {
    char tmpl[] = "/tmp/bidex-tests-XXXXXX";
    if (::mkdtemp(tmpl)) {
      dir = tmpl;
      ::setenv("BIDEX_REGISTRY", (dir + "/registry.sqlite").c_str(), 1);
    }
  }
  const int rc = Catch::Session().run(argc, argv);
  if (!dir.empty()) {
    for (const char* f : {"/registry.sqlite", "/registry.sqlite-wal", "/registry.sqlite-shm",
                          "/age_report.svg"})
      ::unlink((dir + f).c_str());
    ::rmdir(dir.c_str());
  }
  return rc;
}
