// The code version recorded with runs and results: `git describe --always --dirty` of the source
// tree at build time (e.g. "34fd25d9a1b2" or "34fd25d9a1b2-dirty"), or $BIDEX_COMMIT when set (for
// builds from a source archive without .git, where it is otherwise "unknown").
#pragma once

#include <string>

namespace bidex {

std::string code_version();

}  // namespace bidex
