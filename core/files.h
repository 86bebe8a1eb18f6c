// File helpers: reading whole files and writing them atomically (temp file + rename).
#pragma once

#include <string>
#include <string_view>

namespace bidex {

// Reads a whole file; throws IoError naming the path when it cannot.
std::string read_file(const std::string& path);

// Writes `content` to `path` atomically: a sibling temp file is written, flushed and renamed over
// `path`, so readers see the old or the new file, never a partial one. Throws IoError.
void write_file_atomic(const std::string& path, std::string_view content);

}  // namespace bidex
