#include "core/version.h"

#include <cstdlib>

namespace bidex {

const char* built_version();  // generated at build time (cmake/BidexVersion.cmake)

std::string code_version() {
  if (const char* c = std::getenv("BIDEX_COMMIT"); c && *c) return c;
  return built_version();
}

}  // namespace bidex
