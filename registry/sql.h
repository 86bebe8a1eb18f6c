// A thin RAII layer over the sqlite3 C API for the registry: prepared statements with typed
// binding and reading, and write transactions (BEGIN IMMEDIATE ... COMMIT, rolled back when an
// exception leaves the scope). Every failure is a bidex::Error naming the registry file.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <sqlite3.h>

#include "core/error.h"

namespace bidex::registry::sql {

// Concatenation by append (GCC 12 at -O3 warns, -Werror=restrict, on "literal" + std::string&&).
template <class... A>
std::string cat(const A&... a) {
  std::string s;
  (s.append(a), ...);
  return s;
}

// "PATH: what: SQLite's message"
[[noreturn]] inline void fail(sqlite3* db, const std::string& path, const std::string& what) {
  std::string msg = path;
  msg.append(": ").append(what).append(": ").append(db ? sqlite3_errmsg(db) : "out of memory");
  throw Error(msg);
}

// Runs one or more statements without results.
inline void exec(sqlite3* db, const std::string& path, const std::string& sql) {
  char* err = nullptr;
  if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    std::string msg = path;
    msg.append(": ").append(err ? err : sqlite3_errmsg(db));
    sqlite3_free(err);
    throw Error(msg);
  }
}

class Stmt {
 public:
  Stmt(sqlite3* db, const std::string& path, const char* sql) : db_(db), path_(path) {
    if (sqlite3_prepare_v2(db, sql, -1, &s_, nullptr) != SQLITE_OK)
      fail(db, path, std::string("cannot prepare '").append(sql).append("'"));
  }
  ~Stmt() { sqlite3_finalize(s_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  // Parameters are numbered from 1.
  Stmt& bind(int i, const std::string& v) {
    check(sqlite3_bind_text(s_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
    return *this;
  }
  Stmt& bind(int i, const char* v) { return bind(i, std::string(v)); }
  Stmt& bind(int i, int64_t v) {
    check(sqlite3_bind_int64(s_, i, v));
    return *this;
  }
  Stmt& bind(int i, int v) { return bind(i, static_cast<int64_t>(v)); }
  Stmt& bind(int i, double v) {
    check(sqlite3_bind_double(s_, i, v));
    return *this;
  }
  Stmt& bind(int i, const std::optional<double>& v) {
    check(v ? sqlite3_bind_double(s_, i, *v) : sqlite3_bind_null(s_, i));
    return *this;
  }

  // One step: true while a row is ready, false when done.
  bool step() {
    const int rc = sqlite3_step(s_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    fail(db_, path_, std::string("'").append(sqlite3_sql(s_)).append("' failed"));
  }
  // Runs a statement without results to completion.
  void run() {
    while (step()) {
    }
  }
  void reset() {
    sqlite3_reset(s_);
    sqlite3_clear_bindings(s_);
  }

  // Columns are numbered from 0.
  bool null(int c) const { return sqlite3_column_type(s_, c) == SQLITE_NULL; }
  int64_t i64(int c) const { return sqlite3_column_int64(s_, c); }
  int i32(int c) const { return sqlite3_column_int(s_, c); }
  double dbl(int c) const { return sqlite3_column_double(s_, c); }
  std::optional<double> opt(int c) const {
    if (null(c)) return std::nullopt;
    return dbl(c);
  }
  std::string text(int c) const {
    const unsigned char* t = sqlite3_column_text(s_, c);
    return t ? std::string(reinterpret_cast<const char*>(t),
                           static_cast<size_t>(sqlite3_column_bytes(s_, c)))
             : std::string();
  }

 private:
  void check(int rc) {
    if (rc != SQLITE_OK) fail(db_, path_, "cannot bind a value");
  }
  sqlite3* db_;
  const std::string& path_;
  sqlite3_stmt* s_ = nullptr;
};

// A write transaction: BEGIN IMMEDIATE takes the write lock at once (waiting up to the busy
// timeout while another process holds it), so two writers never deadlock on a lock upgrade.
// Commit explicitly; leaving the scope otherwise rolls back.
class WriteTxn {
 public:
  WriteTxn(sqlite3* db, const std::string& path) : db_(db), path_(path) {
    exec(db, path, "BEGIN IMMEDIATE");
  }
  ~WriteTxn() {
    if (open_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  WriteTxn(const WriteTxn&) = delete;
  WriteTxn& operator=(const WriteTxn&) = delete;
  void commit() {
    exec(db_, path_, "COMMIT");
    open_ = false;
  }

 private:
  sqlite3* db_;
  const std::string& path_;
  bool open_ = true;
};

}  // namespace bidex::registry::sql
