// Wall-clock time as recorded in run folders, results and the registry.
#pragma once

#include <string>

namespace bidex {

// The current UTC time, ISO-8601 to the second: "2026-11-22T15:58:21Z".
std::string utc_now();

}  // namespace bidex
