// Helpers of the registry tests: a temp folder (mkdtemp, removed with its content), the registry
// file read directly through the sqlite3 C API, and the expected age order of the paper's tasks
// written out by hand.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include <ftw.h>
#include <sqlite3.h>
#include <unistd.h>

#include <catch2/catch.hpp>

#include "core/files.h"

namespace bidex::test {

// A fresh folder under /tmp (or $TMPDIR), removed with everything in it at scope end.
class RegTempDir {
 public:
  RegTempDir() {
    const char* base = std::getenv("TMPDIR");
    std::string tmpl = (base && *base) ? base : "/tmp";
    tmpl.append("/bidex_registry_test_XXXXXX");
    std::vector<char> buf(tmpl.begin(), tmpl.end());
    buf.push_back('\0');
    if (!::mkdtemp(buf.data())) throw std::runtime_error("cannot create a temp folder");
    path_ = buf.data();
  }
  ~RegTempDir() {
    ::nftw(path_.c_str(),
           [](const char* p, const struct stat*, int, struct FTW*) { return ::remove(p); }, 16,
           FTW_DEPTH | FTW_PHYS);
  }
  RegTempDir(const RegTempDir&) = delete;
  RegTempDir& operator=(const RegTempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string file(const std::string& name) const {
    std::string f = path_;
    f.append("/").append(name);
    return f;
  }

 private:
  std::string path_;
};

inline bool file_exists(const std::string& path) { return ::access(path.c_str(), F_OK) == 0; }

// The registry file opened directly (no bidex code), for PRAGMAs and hand-made old files.
class RawDb {
 public:
  explicit RawDb(const std::string& path) {
    REQUIRE(sqlite3_open(path.c_str(), &db_) == SQLITE_OK);
  }
  ~RawDb() { sqlite3_close(db_); }
  RawDb(const RawDb&) = delete;
  RawDb& operator=(const RawDb&) = delete;
  void exec(const std::string& sql) {
    char* err = nullptr;
    const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err);
    INFO("SQL: " << sql << "\nerror: " << (err ? err : ""));
    sqlite3_free(err);
    REQUIRE(rc == SQLITE_OK);
  }
  // The first column of every row of a query, as text ("NULL" for null).
  std::vector<std::string> column(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    INFO("SQL: " << sql);
    REQUIRE(sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) == SQLITE_OK);
    std::vector<std::string> out;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
      const unsigned char* t = sqlite3_column_text(st, 0);
      out.push_back(t ? reinterpret_cast<const char*>(t) : "NULL");
    }
    sqlite3_finalize(st);
    REQUIRE(rc == SQLITE_DONE);
    return out;
  }
  std::string value(const std::string& sql) {
    auto c = column(sql);
    REQUIRE(c.size() == 1);
    return c[0];
  }

 private:
  sqlite3* db_ = nullptr;
};

// The paper's twenty tasks by human age (months: min, then max), ties by id; worked out by hand
// from the paper's task table (adult = 216 months).
inline const std::vector<std::string>& paper_tasks_by_age() {
  static const std::vector<std::string> ids = {
      "push_block",                                           // 5-6
      "pen", "scissors",                                      // 7
      "catch_abreast", "catch_over2underarm", "hand_over",    // 9-10
      "swing_cup", "switch",                                  // 11
      "lift_underarm",                                        // 12
      "door_close_inward", "door_close_outward", "door_open_inward", "door_open_outward",  // 13
      "re_orientation",                                       // 18
      "block_stack", "grasp_and_place",                       // 22-28
      "bottle_cap",                                           // 30
      "catch_underarm", "pour_water",                         // 48
      "two_catch_underarm",                                   // adult
  };
  return ids;
}

// A file written into a test folder and named by the environment variable `var` (for this
// process and the bidex processes it starts) for the life of this object.
class ScopedFileEnv {
 public:
  ScopedFileEnv(const char* var, const std::string& path, const std::string& text) : var_(var) {
    write_file_atomic(path, text);
    ::setenv(var_, path.c_str(), 1);
  }
  ~ScopedFileEnv() { ::unsetenv(var_); }
  ScopedFileEnv(const ScopedFileEnv&) = delete;
  ScopedFileEnv& operator=(const ScopedFileEnv&) = delete;

 private:
  const char* var_;
};

// For tests that set every random score themselves: the shipped references.yaml without its
// measured `random:` section, in `dir`, named by BIDEX_REFERENCES.
class GroundTruthOnly : ScopedFileEnv {
 public:
  explicit GroundTruthOnly(const RegTempDir& dir)
      : ScopedFileEnv("BIDEX_REFERENCES", dir.file("ground_truth_only.yaml"), text()) {}

 private:
  static std::string text() {
    std::string text = read_file(BIDEX_SOURCE_DIR "/configs/registry/references.yaml");
    const size_t cut = text.find("\nrandom:");
    REQUIRE(cut != std::string::npos);
    text.resize(cut + 1);
    return text;
  }
};

// The shipped configs/registry/time_to_goal.yaml with one task's entry as a run that did not meet
// its goal (trained 50,069,504 slot-steps), loaded in its place ($BIDEX_TIME_TO_GOAL) while
// alive: every task of the shipped file has met its goal since the twenty-third lease, and the
// report's path for one that has not still needs a row.
class TimeToGoalWithOneNotMet : ScopedFileEnv {
 public:
  TimeToGoalWithOneNotMet(const RegTempDir& dir, const std::string& task)
      : ScopedFileEnv("BIDEX_TIME_TO_GOAL", dir.file("time_to_goal_one_not_met.yaml"),
                      text(task)) {}

 private:
  static std::string text(const std::string& task) {
    std::string text = read_file(BIDEX_SOURCE_DIR "/configs/registry/time_to_goal.yaml");
    std::string key = "\n  ";
    key.append(task).append(":\n");
    const size_t at = text.find(key);
    REQUIRE(at != std::string::npos);
    const size_t body = at + key.size();
    size_t end = body;  // the entry's lines are indented by four spaces
    while (end < text.size() && text.compare(end, 4, "    ") == 0) end = text.find('\n', end) + 1;
    std::string entry = text.substr(body, end - body);
    auto set = [&](const std::string& k, const std::string& v) {
      const std::string at_k = "    " + k + ": ";
      const size_t p = entry.find(at_k);
      REQUIRE(p != std::string::npos);
      entry.replace(p + at_k.size(), entry.find('\n', p) - p - at_k.size(), v);
    };
    set("trained", "50069504");
    set("by", "not_reached");
    set("slot_steps", "null");
    set("wall_s", "null");
    text.replace(body, end - body, entry);
    return text;
  }
};

inline bool has_text(const std::string& s, const std::string& what) {
  return s.find(what) != std::string::npos;
}

// The whitespace-separated words of every line of `out`.
inline std::vector<std::vector<std::string>> table_lines(const std::string& out) {
  std::vector<std::vector<std::string>> lines(1);
  std::string word;
  for (char c : out + "\n") {
    if (c == ' ' || c == '\t' || c == '\n') {
      if (!word.empty()) lines.back().push_back(word);
      word.clear();
      if (c == '\n') lines.emplace_back();
    } else {
      word += c;
    }
  }
  return lines;
}

// Whether `out` has a line made of exactly these words (any spacing).
inline bool has_row(const std::string& out, const std::vector<std::string>& words) {
  for (auto& l : table_lines(out))
    if (l == words) return true;
  return false;
}

}  // namespace bidex::test
