#include "apps/programs.h"

#include <cstdio>
#include <cstdlib>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/error.h"

extern char** environ;

namespace bidex::apps {

std::string find_on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::string p = path ? path : "";
  size_t a = 0;
  while (a <= p.size()) {
    size_t c = p.find(':', a);
    if (c == std::string::npos) c = p.size();
    std::string cand = p.substr(a, c - a);
    cand.append("/").append(name);
    if (c > a && ::access(cand.c_str(), X_OK) == 0) return cand;
    a = c + 1;
  }
  return "";
}

int run_program(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid;
  if (::posix_spawn(&pid, args[0].c_str(), nullptr, nullptr, argv.data(), environ) != 0) return -1;
  int status = 0;
  if (::waitpid(pid, &status, 0) < 0) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string without_svg(const std::string& path) {
  const std::string ext = ".svg";
  const bool has = path.size() > ext.size() && path.compare(path.size() - ext.size(), ext.size(),
                                                            ext) == 0;
  return has ? path.substr(0, path.size() - ext.size()) : path;
}

std::string png_beside(const std::string& svg) {
  const std::string rsvg = find_on_path("rsvg-convert");
  if (rsvg.empty())
    return "rsvg-convert is not on PATH: no PNG of " + svg + " (apt-get install librsvg2-bin)";
  const std::string png = without_svg(svg) + ".png", tmp = png + ".tmp.png";
  const int rc = run_program({rsvg, "--format", "png", "--background-color", "white", "--output",
                              tmp, svg});
  if (rc != 0 || std::rename(tmp.c_str(), png.c_str()) != 0) {
    ::unlink(tmp.c_str());
    throw Error("rsvg-convert (" + rsvg + ") failed to draw " + svg + " as " + png + " (exit " +
                std::to_string(rc) + ")");
  }
  return "png: " + png;
}

}  // namespace bidex::apps
