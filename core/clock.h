// Wall-clock time as recorded in run folders, results and the registry, and a monotonic clock
// for measuring durations.
#pragma once

#include <string>

namespace bidex {

// The current UTC time, ISO-8601 to the second: "2026-11-22T15:58:21Z".
std::string utc_now();

// Seconds on a monotonic clock (std::chrono::steady_clock) from an arbitrary origin: differences
// of two readings are durations.
double monotonic_seconds();

}  // namespace bidex
