// Idle worker threads that sleep instead of spinning. The CPU path runs two thread pools in one
// process: the simulation's OpenMP (libgomp) threads and OpenBLAS's threads under LibTorch. By
// default each pool's idle threads spin for a while before sleeping, and on a machine with few
// cores the spinning pool takes the cores the other pool is waiting for. Both libraries read how
// long to spin once, from the environment, when they are initialised, before main; and libc's
// own initialiser resets the environment that an earlier function could change. Hence
// `rest_idle_threads`. The numbers do not change: only how idle threads wait.
// Measured on two cores: bench/results/idle-threads-2core.txt.
#pragma once

#include <cstddef>
#include <iterator>

namespace bidex {

// The variables and the values `rest_idle_threads` gives them when unset.
struct IdleThreadSetting {
  const char* name;
  const char* value;
};
inline constexpr IdleThreadSetting kIdleThreadSettings[] = {
    {"OMP_WAIT_POLICY", "passive"},    // libgomp: idle threads sleep at once
    {"OPENBLAS_THREAD_TIMEOUT", "4"},  // OpenBLAS: spin 2^4 cycles (its minimum), then sleep
};
inline constexpr size_t kIdleThreadSettingCount = std::size(kIdleThreadSettings);

// If a variable of kIdleThreadSettings is unset, executes this program again (/proc/self/exe)
// with the same arguments and the variables added; a value the user gave wins (e.g.
// OMP_WAIT_POLICY=active). Returns if all are set, or if the program cannot be executed again
// (it then runs on with spinning threads). It has the signature of a .preinit_array entry and
// must run there: the libraries are loaded but none is initialised, so the second start costs
// only the loading.
void rest_idle_threads(int argc, char** argv, char** envp);

// What rest_idle_threads does with the program `exe` (the tests start /usr/bin/env with it).
void exec_with_idle_threads(const char* exe, char** argv, char** envp);

}  // namespace bidex

// In the file of an executable's main, at namespace scope: runs bidex::rest_idle_threads before
// any library's initialiser (an ELF executable's preinit array; shared libraries have none).
#define BIDEX_REST_IDLE_THREADS_BEFORE_LIBRARIES                                       \
  [[gnu::used, gnu::section(".preinit_array")]] static void (                          \
      *const bidex_rest_idle_threads_entry)(int, char**, char**) = &bidex::rest_idle_threads
