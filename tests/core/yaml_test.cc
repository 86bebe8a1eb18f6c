// core/yaml: strict YAML views whose every error names the file, key path, expected and actual.
#include "core/yaml.h"

#include <climits>
#include <cstdlib>

#include <catch2/catch.hpp>

#include "core/error.h"
#include "tests/fixture.h"

using bidex::ConfigError;
using bidex::YamlView;
using bidex::test::check_config_error;
using bidex::test::config_error;

namespace {

const char* kDoc = R"(name: hand
count: 7
ratio: 0.25
flag: true
tags: [a, b, c]
values: [1, 2.5, -3]
pair: [0.5, 1.5]
nested:
  inner: {x: 1, y: [4, 5, 6]}
  items:
    - {id: 0, w: 1.0}
    - {id: 1, w: twelve}
    - {id: 2, w: [1, 2]}
)";

}  // namespace

TEST_CASE("ConfigError composes file, key, expected and actual", "[core][yaml]") {
  ConfigError e("cfg/x.yaml:3", "bodies[1].mass", "a number > 0", "-1");
  CHECK(std::string(e.what()) == "cfg/x.yaml:3: bodies[1].mass: expected a number > 0, got -1");
  CHECK(e.file() == "cfg/x.yaml:3");
  CHECK(e.key() == "bodies[1].mass");
  CHECK(e.expected() == "a number > 0");
  CHECK(e.actual() == "-1");
  ConfigError anon("", "", "a thing", "another");
  CHECK(std::string(anon.what()) == "<input>: expected a thing, got another");
}

TEST_CASE("YamlView reads scalars, lists and nested keys with their paths", "[core][yaml]") {
  auto root = YamlView::load_string(kDoc, "doc.yaml");
  CHECK(root.file() == "doc.yaml");
  CHECK(root.path().empty());
  CHECK(root.is_map());
  CHECK(root.req<std::string>("name") == "hand");
  CHECK(root.req<int>("count") == 7);
  CHECK(root.req<double>("ratio") == 0.25);
  CHECK(root.req<double>("count") == 7.0);
  CHECK(root.req<bool>("flag") == true);
  CHECK(root.req<std::vector<std::string>>("tags") == std::vector<std::string>{"a", "b", "c"});
  CHECK(root.req<std::vector<double>>("values") == std::vector<double>{1, 2.5, -3});
  CHECK(root.req<std::array<double, 2>>("pair") == std::array<double, 2>{0.5, 1.5});
  CHECK(root.child("nested").child("inner").req<std::array<double, 3>>("y") ==
        std::array<double, 3>{4, 5, 6});
  CHECK(root.keys() == std::vector<std::string>{"name", "count", "ratio", "flag", "tags",
                                                 "values", "pair", "nested"});

  auto items = root.child("nested").child("items").items();
  REQUIRE(items.size() == 3);
  CHECK(items[1].path() == "nested.items[1]");
  CHECK(items[1].child("w").path() == "nested.items[1].w");
  CHECK(items[0].req<double>("w") == 1.0);

  CHECK(root.has("ratio"));
  CHECK_FALSE(root.has("missing"));
  CHECK_FALSE(root.maybe("missing").has_value());
  CHECK(root.maybe("count")->path() == "count");
  CHECK(root.opt<double>("missing", 4.5) == 4.5);
  CHECK(root.opt<double>("ratio", 4.5) == 0.25);
  CHECK(root.opt<std::string>("name", "x") == "hand");
}

TEST_CASE("YamlView conversion errors name file, key path, expected and actual",
          "[core][yaml]") {
  auto root = YamlView::load_string(kDoc, "doc.yaml");
  auto items = root.child("nested").child("items").items();

  SECTION("a string where a number is expected") {
    auto e = config_error([&] { items[1].req<double>("w"); });
    check_config_error(e, "doc.yaml", "nested.items[1].w", "a number", "'twelve'");
    CHECK(e.file() == "doc.yaml:12");  // the line of the bad value
  }
  SECTION("a list where a number is expected") {
    auto e = config_error([&] { items[2].req<double>("w"); });
    check_config_error(e, "doc.yaml", "nested.items[2].w", "a number", "[1, 2]");
  }
  SECTION("a fraction where an integer is expected") {
    auto e = config_error([&] { root.req<int>("ratio"); });
    check_config_error(e, "doc.yaml", "ratio", "an integer", "0.25");
  }
  SECTION("not a boolean") {
    auto e = config_error([&] { root.req<bool>("name"); });
    check_config_error(e, "doc.yaml", "name", "true or false", "hand");
  }
  SECTION("a map where a string is expected") {
    auto e = config_error([&] { root.child("nested").req<std::string>("inner"); });
    check_config_error(e, "doc.yaml", "nested.inner", "a string", "x: 1");
  }
  SECTION("a list of the wrong length") {
    auto e = config_error([&] { root.req<std::array<double, 3>>("pair"); });
    check_config_error(e, "doc.yaml", "pair", "a list of 3 numbers", "[0.5, 1.5]");
  }
  SECTION("a bad element inside a list names its index") {
    auto e = config_error([&] { root.req<std::vector<double>>("tags"); });
    check_config_error(e, "doc.yaml", "tags[0]", "a number", "a");
  }
  SECTION("a scalar where a list is expected") {
    auto e = config_error([&] { root.req<std::vector<double>>("count"); });
    check_config_error(e, "doc.yaml", "count", "a list of numbers", "7");
  }
  SECTION("a missing required key") {
    auto e = config_error([&] { root.child("nested").child("inner").req<double>("z"); });
    check_config_error(e, "doc.yaml", "nested.inner.z", "a value for the required key", "none");
  }
  SECTION("items() of a map") {
    auto e = config_error([&] { root.child("nested").child("inner").items(); });
    check_config_error(e, "doc.yaml", "nested.inner", "a list", "x: 1");
  }
  SECTION("child() of a scalar") {
    auto e = config_error([&] { root.child("count").child("x"); });
    check_config_error(e, "doc.yaml", "count", "a mapping of keys to values", "7");
  }
  SECTION("fail() at the top level") {
    auto e = config_error([&] { root.fail("something", "else"); });
    check_config_error(e, "doc.yaml", "(top level)", "something", "else");
  }
}

TEST_CASE("YamlView rejects non-finite numbers", "[core][yaml]") {
  auto v = YamlView::load_string("a: .nan\nb: .inf\nc: -.inf\n", "nf.yaml");
  for (const char* key : {"a", "b", "c"}) {
    INFO(key);
    auto e = config_error([&] { v.req<double>(key); });
    check_config_error(e, "nf.yaml", key, "a finite number", "");
  }
}

TEST_CASE("allow_keys names the first unknown key and the allowed ones", "[core][yaml]") {
  auto root = YamlView::load_string("top:\n  alpha: 1\n  gamma: 2\n  delta: 3\n", "keys.yaml");
  auto top = root.child("top");
  top.allow_keys({"alpha", "gamma", "delta"});  // all known: no throw
  auto e = config_error([&] { top.allow_keys({"alpha", "beta"}); });
  check_config_error(e, "keys.yaml", "top.gamma", "one of the keys {alpha, beta}",
                     "unknown key 'gamma'");
  CHECK(e.file() == "keys.yaml:3");
  auto e2 = config_error([&] { root.child("top").child("alpha").allow_keys({"x"}); });
  check_config_error(e2, "keys.yaml", "top.alpha", "a mapping of keys to values", "1");
}

TEST_CASE("YAML syntax errors and missing files", "[core][yaml]") {
  bidex::test::TempDir dir;
  SECTION("a syntax error is a ConfigError with the line") {
    std::string path = dir.file("broken.yaml");
    bidex::write_file_atomic(path, "a: 1\nb: [1, 2\nc: 3\n");
    auto e = config_error([&] { YamlView::load_file(path); });
    std::string what = e.what();
    INFO(what);
    CHECK(e.file().rfind(path + ":", 0) == 0);
    CHECK(e.expected() == "valid YAML");
    CHECK(e.actual().find("syntax error") != std::string::npos);
  }
  SECTION("a missing file is an IoError naming the path") {
    std::string path = dir.file("does_not_exist.yaml");
    try {
      YamlView::load_file(path);
      FAIL("no error for a missing file");
    } catch (const bidex::IoError& e) {
      CHECK(std::string(e.what()).find(path) != std::string::npos);
    }
  }
  SECTION("a file loads with its path as the file name") {
    std::string path = dir.file("ok.yaml");
    bidex::write_file_atomic(path, "x: [1, 2]\n");
    auto v = YamlView::load_file(path);
    CHECK(v.file() == path);
    auto e = config_error([&] { v.req<double>("x"); });
    check_config_error(e, path, "x", "a number", "[1, 2]");
  }
}

// ---- extends: a file as its parent with this file's keys merged over it ------------------------

namespace {

const char* kParent = R"(name: base
count: 3
list: [1, 2, 3]
object: egg
nested:
  a: 1
  b: {x: 1, y: 2}
  c: [4, 5]
)";

std::string realpath_of(const std::string& p) {
  char buf[PATH_MAX];
  REQUIRE(::realpath(p.c_str(), buf) != nullptr);
  return buf;
}

}  // namespace

TEST_CASE("extends merges a file's keys over its parent's", "[core][yaml]") {
  bidex::test::TempDir dir;
  const std::string parent = dir.file("parent.yaml");
  bidex::write_file_atomic(parent, kParent);
  const std::string child = dir.file("child.yaml");
  bidex::write_file_atomic(child, "extends: parent.yaml\ncount: 7\nlist: [9]\n"
                                  "object: {type: mjcf, file: body.xml}\n"
                                  "nested:\n  b: {y: 20}\n  c: []\n");
  const YamlView v = YamlView::load_file(child);
  CHECK(v.file() == child + " (extends " + realpath_of(parent) + ")");
  // the parent's keys, in the parent's order; no `extends`
  CHECK(v.keys() == std::vector<std::string>{"name", "count", "list", "object", "nested"});
  CHECK(v.req<std::string>("name") == "base");                    // kept
  CHECK(v.req<int>("count") == 7);                                // scalar replaced
  CHECK(v.req<std::vector<double>>("list") == std::vector<double>{9});  // list replaced whole
  CHECK(v.child("object").req<std::string>("type") == "mjcf");    // a map over a scalar
  const YamlView n = v.child("nested");
  CHECK(n.req<int>("a") == 1);                                    // maps merge key by key
  CHECK(n.child("b").req<int>("x") == 1);
  CHECK(n.child("b").req<int>("y") == 20);
  CHECK(n.child("c").items().empty());
  // messages name the merged file, without a line number (the value may come from either file)
  auto e = config_error([&] { v.req<double>("name"); });
  check_config_error(e, child + " (extends ", "name", "a number", "'base'");
  CHECK(e.file() == v.file());
  auto e2 = config_error([&] { n.child("b").allow_keys({"x"}); });
  CHECK(e2.file() == v.file());
  CHECK(e2.key() == "nested.b.y");

  SECTION("a file without extends keeps its lines") {
    auto p = YamlView::load_file(parent);
    CHECK(p.file() == parent);
    CHECK(config_error([&] { p.req<double>("name"); }).file() == parent + ":1");
  }
  SECTION("chains: a grandchild over the merged child") {
    const std::string sub = dir.file("sub");
    bidex::write_file_atomic(sub + "/grandchild.yaml",
                             "extends: ../child.yaml\nnested: {a: 5}\ncount: 8\n");
    const YamlView g = YamlView::load_file(sub + "/grandchild.yaml");
    CHECK(g.file() == sub + "/grandchild.yaml (extends " + realpath_of(child) + " (extends " +
                           realpath_of(parent) + "))");
    CHECK(g.req<int>("count") == 8);
    CHECK(g.child("nested").req<int>("a") == 5);
    CHECK(g.child("nested").child("b").req<int>("y") == 20);  // from the child
    CHECK(g.req<std::vector<double>>("list") == std::vector<double>{9});
  }
}

TEST_CASE("extends is strict: unknown keys, missing parents and cycles are errors",
          "[core][yaml]") {
  bidex::test::TempDir dir;
  const std::string parent = dir.file("parent.yaml");
  bidex::write_file_atomic(parent, kParent);
  SECTION("a key the parent lacks names this file, the key path and the parent's keys") {
    const std::string child = dir.file("typo.yaml");
    bidex::write_file_atomic(child, "extends: parent.yaml\nnested:\n  b: {x: 2, z: 3}\n");
    auto e = config_error([&] { YamlView::load_file(child); });
    check_config_error(e, child, "nested.b.z", "a key of " + realpath_of(parent) + " {x, y}",
                       "unknown key 'z'");
    CHECK(e.file() == child + ":3");
    const std::string top = dir.file("top.yaml");
    bidex::write_file_atomic(top, "extends: parent.yaml\ncolour: red\n");
    auto e2 = config_error([&] { YamlView::load_file(top); });
    check_config_error(e2, top, "colour", "{name, count, list, object, nested}",
                       "unknown key 'colour'");
  }
  SECTION("a missing parent names this file and `extends`") {
    const std::string child = dir.file("orphan.yaml");
    bidex::write_file_atomic(child, "extends: nowhere/parent.yaml\ncount: 1\n");
    auto e = config_error([&] { YamlView::load_file(child); });
    check_config_error(e, child, "extends", "a readable YAML file", "'nowhere/parent.yaml'");
  }
  SECTION("extends must be a path") {
    const std::string child = dir.file("list.yaml");
    bidex::write_file_atomic(child, "extends: [parent.yaml]\n");
    auto e = config_error([&] { YamlView::load_file(child); });
    check_config_error(e, child, "extends", "a string", "[parent.yaml]");
  }
  SECTION("a cycle, and a file extending itself") {
    bidex::write_file_atomic(dir.file("a.yaml"), "extends: b.yaml\ncount: 1\n");
    bidex::write_file_atomic(dir.file("b.yaml"), "extends: a.yaml\ncount: 2\n");
    auto e = config_error([&] { YamlView::load_file(dir.file("a.yaml")); });
    CHECK(e.key() == "extends");
    CHECK(e.expected() == "a chain of files without a cycle");
    CHECK(e.actual().find("a.yaml -> ") != std::string::npos);
    bidex::write_file_atomic(dir.file("self.yaml"), "extends: ./self.yaml\ncount: 1\n");
    auto e2 = config_error([&] { YamlView::load_file(dir.file("self.yaml")); });
    CHECK(e2.key() == "extends");
    CHECK(e2.actual().find("cycle") != std::string::npos);
  }
  SECTION("the parent must be a map") {
    bidex::write_file_atomic(dir.file("seq.yaml"), "[1, 2]\n");
    bidex::write_file_atomic(dir.file("over_seq.yaml"), "extends: seq.yaml\n");
    auto e = config_error([&] { YamlView::load_file(dir.file("over_seq.yaml")); });
    CHECK(e.expected() == "a mapping of keys to values");
    CHECK(e.file().find("seq.yaml") != std::string::npos);
  }
}
