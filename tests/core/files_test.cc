// core/files: whole-file reads and atomic writes (temp file + rename), errors naming the path.
#include "core/files.h"

#include <fstream>
#include <iterator>

#include <catch2/catch.hpp>

#include "core/error.h"
#include "tests/fixture.h"

using bidex::IoError;
using bidex::read_file;
using bidex::write_file_atomic;
using bidex::test::TempDir;

namespace {

// Runs `f`, which must throw an IoError; returns its message.
std::string io_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const IoError& e) {
    return e.what();
  }
  FAIL("expected an IoError, none was thrown");
  return "";
}

}  // namespace

TEST_CASE("write_file_atomic writes a new file and read_file reads it back", "[core][files]") {
  TempDir dir;
  std::string path = dir.file("out.txt");
  std::string content = "line one\nline two\n";
  content.push_back('\0');  // binary-safe
  content += "after a NUL byte";
  write_file_atomic(path, content);
  CHECK(read_file(path) == content);
  CHECK(dir.list() == std::vector<std::string>{"out.txt"});  // no temp file left

  SECTION("an empty file") {
    write_file_atomic(path, "");
    CHECK(read_file(path).empty());
    CHECK(std::filesystem::file_size(path) == 0);
  }
}

TEST_CASE("write_file_atomic replaces an existing file and leaves no temp file",
          "[core][files]") {
  TempDir dir;
  std::string path = dir.file("model.xml");
  write_file_atomic(path, std::string(100000, 'a'));
  write_file_atomic(path, "short");
  CHECK(read_file(path) == "short");  // fully replaced, not overwritten in place
  CHECK(dir.list() == std::vector<std::string>{"model.xml"});

  // a reader holding the old file keeps seeing the old content (a new inode was renamed in)
  std::ifstream held(path);
  write_file_atomic(path, "newest");
  std::string seen((std::istreambuf_iterator<char>(held)), std::istreambuf_iterator<char>());
  CHECK(seen == "short");
  CHECK(read_file(path) == "newest");
}

TEST_CASE("write_file_atomic creates missing parent folders", "[core][files]") {
  TempDir dir;
  std::string path = dir.file("a/b/c/out.json");
  write_file_atomic(path, "{}");
  CHECK(read_file(path) == "{}");
  CHECK(dir.list() == std::vector<std::string>{"a"});
}

TEST_CASE("write_file_atomic fails with an IoError naming the path", "[core][files]") {
  TempDir dir;
  std::string blocker = dir.file("regular_file");
  write_file_atomic(blocker, "I am a file, not a folder");

  SECTION("a folder that is a regular file") {
    std::string path = blocker + "/out.txt";
    std::string msg = io_error([&] { write_file_atomic(path, "x"); });
    INFO(msg);
    CHECK(msg.find(path) != std::string::npos);
  }
  SECTION("a folder below a regular file") {
    std::string path = blocker + "/sub/out.txt";
    std::string msg = io_error([&] { write_file_atomic(path, "x"); });
    INFO(msg);
    CHECK(msg.find(path) != std::string::npos);
    CHECK(msg.find("folder") != std::string::npos);
  }
  SECTION("a target that is a folder: rename fails, the temp file is removed") {
    std::string path = dir.file("a_folder");
    std::filesystem::create_directory(path);
    std::string msg = io_error([&] { write_file_atomic(path, "x"); });
    INFO(msg);
    CHECK(msg.find(path) != std::string::npos);
    CHECK(dir.list() == std::vector<std::string>{"a_folder", "regular_file"});
    CHECK(std::filesystem::is_empty(path));
  }
  CHECK(read_file(blocker) == "I am a file, not a folder");
}

TEST_CASE("read_file of a missing file is an IoError naming the path", "[core][files]") {
  TempDir dir;
  std::string path = dir.file("missing.txt");
  std::string msg = io_error([&] { read_file(path); });
  INFO(msg);
  CHECK(msg.find(path) != std::string::npos);
  CHECK(msg.find("No such file") != std::string::npos);
}
