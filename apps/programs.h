// Other programs a command may call when they are installed: ffmpeg (bidex render's MP4) and
// rsvg-convert (PNG copies of SVG plots).
#pragma once

#include <string>
#include <vector>

namespace bidex::apps {

// The first `name` on PATH that can be executed, or "".
std::string find_on_path(const std::string& name);

// Runs a program with arguments, waits; returns its exit status (-1 if it could not start).
int run_program(const std::vector<std::string>& args);

// `svg` drawn as a PNG beside it (its name with .png for .svg), written atomically, by
// rsvg-convert when it is on PATH. Returns the line to print: the PNG's path, or that
// rsvg-convert is missing and how to install it. A failed conversion is an Error naming both
// files; nothing is left half-written.
std::string png_beside(const std::string& svg);

// `path` without a final ".svg", for the files written beside a plot.
std::string without_svg(const std::string& path);

}  // namespace bidex::apps
