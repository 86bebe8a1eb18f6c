// sim/hand_spec: the hand YAML is read, validated, and matches the paper's joint table; bad
// files are ConfigErrors that name the file, key path, expected and actual value.
#include "sim/hand_spec.h"

#include <catch2/catch.hpp>

#include "core/files.h"
#include "core/yaml.h"
#include "tests/fixture.h"
#include "tests/paper_table.h"

using namespace bidex;
using namespace bidex::sim;
using bidex::test::check_config_error;
using bidex::test::config_error;
using bidex::test::kPaperJoints;
using bidex::test::line_of;
using bidex::test::replace_once;
using bidex::test::shadow;
using bidex::test::TempDir;

TEST_CASE("shadow.yaml matches the paper's joint table", "[sim][hand_spec]") {
  const HandSpec& spec = shadow();
  CHECK(spec.name == "shadow");
  CHECK(spec.side == Side::kRight);
  CHECK(spec.file == default_hand_path());

  auto joints = spec.joints();
  REQUIRE(joints.size() == kPaperJoints.size());
  std::vector<std::string> expected_actuated;
  for (size_t i = 0; i < joints.size(); ++i) {
    const auto& want = kPaperJoints[i];
    INFO("joint " << i << ": " << want.name);
    CHECK(joints[i]->name == want.name);
    CHECK(joints[i]->min_deg == want.min_deg);
    CHECK(joints[i]->max_deg == want.max_deg);
    CHECK(joints[i]->actuator.has_value() == want.actuated);
    if (want.actuated && joints[i]->actuator) {
      CHECK(joints[i]->actuator->force_limit == want.force_limit);
      CHECK(joints[i]->actuator->kp > 0);
      expected_actuated.push_back(want.name);
    }
    CHECK(spec.joint(want.name) == joints[i]);
  }
  auto actuated = spec.actuated_joints();
  REQUIRE(actuated.size() == 20);
  for (size_t i = 0; i < actuated.size(); ++i) CHECK(actuated[i]->name == expected_actuated[i]);

  // the distal joints follow the middle ones, 1:1 (middle >= distal)
  REQUIRE(spec.couplings.size() == bidex::test::kPaperCouplings.size());
  for (size_t i = 0; i < spec.couplings.size(); ++i) {
    CHECK(spec.couplings[i].joint == bidex::test::kPaperCouplings[i][0]);
    CHECK(spec.couplings[i].follows == bidex::test::kPaperCouplings[i][1]);
    CHECK(spec.couplings[i].ratio == 1.0);
  }

  // five fingertips with force/torque sensors, tree order: ff, mf, rf, lf, th
  auto sites = spec.sensor_sites();
  REQUIRE(sites.size() == 5);
  std::vector<std::string> tip_names;
  for (auto* s : sites) tip_names.push_back(s->name);
  CHECK(tip_names == std::vector<std::string>{"fftip", "mftip", "rftip", "lftip", "thtip"});

  // a tree: the root first, every parent listed before its children, positive masses
  REQUIRE_FALSE(spec.bodies.empty());
  CHECK(spec.bodies[0].parent.empty());
  CHECK_FALSE(spec.bodies[0].joint.has_value());
  for (size_t i = 1; i < spec.bodies.size(); ++i) {
    const BodySpec* parent = spec.body(spec.bodies[i].parent);
    REQUIRE(parent != nullptr);
    CHECK(parent < &spec.bodies[i]);
  }
  for (auto& b : spec.bodies) {
    CHECK(b.mass > 0);
    CHECK_FALSE(b.geoms.empty());
  }
  for (auto& pair : spec.self_contacts) {
    CHECK(spec.body(pair[0]) != nullptr);
    CHECK(spec.body(pair[1]) != nullptr);
  }
}

TEST_CASE("the mirrored spec is the reflection x -> -x, with the same joints", "[sim][hand_spec]") {
  const HandSpec& r = shadow();
  HandSpec l = r.mirrored();
  CHECK(l.side == Side::kLeft);
  CHECK(r.for_side(Side::kRight).side == Side::kRight);
  CHECK(r.for_side(Side::kLeft).side == Side::kLeft);
  REQUIRE(l.bodies.size() == r.bodies.size());
  for (size_t i = 0; i < r.bodies.size(); ++i) {
    const BodySpec &a = r.bodies[i], &b = l.bodies[i];
    INFO(a.name);
    CHECK(b.name == a.name);
    CHECK(b.parent == a.parent);
    CHECK(b.mass == a.mass);
    CHECK(b.pos == Vec3{-a.pos[0], a.pos[1], a.pos[2]});
    REQUIRE(b.joint.has_value() == a.joint.has_value());
    if (a.joint) {
      CHECK(b.joint->name == a.joint->name);
      // ranges (anatomical meaning) and actuators are unchanged
      CHECK(b.joint->min_deg == a.joint->min_deg);
      CHECK(b.joint->max_deg == a.joint->max_deg);
      CHECK(b.joint->actuator.has_value() == a.joint->actuator.has_value());
      // a rotation axis is a pseudo-vector: reflecting x flips the y and z parts
      CHECK(b.joint->axis == Vec3{a.joint->axis[0], -a.joint->axis[1], -a.joint->axis[2]});
    }
    REQUIRE(b.geoms.size() == a.geoms.size());
    for (size_t g = 0; g < a.geoms.size(); ++g) {
      CHECK(b.geoms[g].from == Vec3{-a.geoms[g].from[0], a.geoms[g].from[1], a.geoms[g].from[2]});
      CHECK(b.geoms[g].to == Vec3{-a.geoms[g].to[0], a.geoms[g].to[1], a.geoms[g].to[2]});
      CHECK(b.geoms[g].pos == Vec3{-a.geoms[g].pos[0], a.geoms[g].pos[1], a.geoms[g].pos[2]});
      CHECK(b.geoms[g].half == a.geoms[g].half);
      CHECK(b.geoms[g].radius == a.geoms[g].radius);
    }
  }
  // mirroring twice gives the original back
  HandSpec rr = l.mirrored();
  CHECK(rr.side == Side::kRight);
  for (size_t i = 0; i < r.bodies.size(); ++i) {
    CHECK(rr.bodies[i].pos == r.bodies[i].pos);
    CHECK(rr.bodies[i].quat == r.bodies[i].quat);
    if (r.bodies[i].joint) CHECK(rr.bodies[i].joint->axis == r.bodies[i].joint->axis);
  }
}

namespace {

// shadow.yaml's text, edited and written to a temp file; returns the path.
struct EditedSpec {
  TempDir dir;
  std::string text, path;
  explicit EditedSpec(const std::string& edited) : text(edited), path(dir.file("hand.yaml")) {
    write_file_atomic(path, text);
  }
};

std::string shadow_text() { return read_file(default_hand_path()); }

}  // namespace

TEST_CASE("the unedited copy of shadow.yaml loads", "[sim][hand_spec]") {
  EditedSpec f(shadow_text());
  HandSpec spec = load_hand_spec(f.path);
  CHECK(spec.file == f.path);
  CHECK(spec.joints().size() == 24);
}

TEST_CASE("bad hand YAML is a ConfigError naming file, key path, expected and actual",
          "[sim][hand_spec]") {
  const std::string base = shadow_text();
  // body indices in shadow.yaml: 0 forearm, 1 wrist, 2 palm, 3 ffknuckle (FF4), ...
  const std::string palm_mass = "    pos: [0, 0, 0.034]\n    mass: 0.3\n";
  const std::string ff4 = "{name: FF4, axis: [0, 1, 0], range_deg: [-20, 20],";

  // each case: an edit of shadow.yaml (from -> to) and the key path, expected and actual parts
  // of the error; `line`: text whose line the error must name ("" when not checked)
  struct BadEdit {
    const char* what;
    std::string from, to, key, expected, actual, line;
  };
  const std::vector<BadEdit> cases = {
      {"an unknown top-level key", "name: shadow\n", "name: shadow\ncolour: red\n", "colour",
       "one of the keys {", "unknown key 'colour'", "colour: red"},
      {"an unknown key in a body", palm_mass, palm_mass + "    colour: red\n", "bodies[2].colour",
       "mass", "unknown key 'colour'", ""},
      {"an unknown key in a joint", ff4,
       "{name: FF4, stiffness: 3, axis: [0, 1, 0], "
       "range_deg: [-20, 20],",
       "bodies[3].joint.stiffness", "range_deg", "unknown key 'stiffness'", ""},
      {"a body without mass", palm_mass, "    pos: [0, 0, 0.034]\n", "bodies[2].mass", "required",
       "none", ""},
      {"a joint without range_deg", ff4, "{name: FF4, axis: [0, 1, 0],",
       "bodies[3].joint.range_deg", "required", "none", ""},
      {"an impossible range, min > max", ff4, "{name: FF4, axis: [0, 1, 0], range_deg: [90, 10],",
       "bodies[3].joint.range_deg", "min < max", "[90, 10]", "name: FF4"},
      {"an empty range, min == max", ff4, "{name: FF4, axis: [0, 1, 0], range_deg: [10, 10],",
       "bodies[3].joint.range_deg", "min < max", "[10, 10]", ""},
      {"a range of three numbers", ff4, "{name: FF4, axis: [0, 1, 0], range_deg: [1, 2, 3],",
       "bodies[3].joint.range_deg", "a list of 2 numbers", "[1, 2, 3]", ""},
      {"a coupling to an unknown joint", "{joint: FF1, follows: FF2, ratio: 1.0}",
       "{joint: FF1, follows: FF9, ratio: 1.0}", "couplings[0].follows", "a joint of this hand",
       "'FF9'", ""},
      {"a coupling of an unknown joint", "{joint: MF1, follows: MF2, ratio: 1.0}",
       "{joint: XX1, follows: MF2, ratio: 1.0}", "couplings[1].joint", "a joint of this hand",
       "'XX1'", ""},
      {"a coupling driving an actuated joint", "{joint: FF1, follows: FF2, ratio: 1.0}",
       "{joint: FF3, follows: FF2, ratio: 1.0}", "couplings[0].joint", "without an actuator",
       "'FF3'", ""},
      {"a coupling ratio above 1 (distal beyond middle)", "{joint: FF1, follows: FF2, ratio: 1.0}",
       "{joint: FF1, follows: FF2, ratio: 1.5}", "couplings[0].ratio", "(0, 1]", "1.5", ""},
      {"a passive joint with neither actuator nor coupling",
       "  - {joint: RF1, follows: RF2, ratio: 1.0}\n", "", "bodies", "'RF1'", "neither", ""},
      {"a string where a number is expected", palm_mass,
       "    pos: [0, 0, 0.034]\n    mass: heavy\n", "bodies[2].mass", "a number", "heavy",
       "mass: heavy"},
      {"a string inside a range", ff4, "{name: FF4, axis: [0, 1, 0], range_deg: [-20, twenty],",
       "bodies[3].joint.range_deg[1]", "a number", "twenty", ""},
      {"a negative mass", palm_mass, "    pos: [0, 0, 0.034]\n    mass: -0.3\n", "bodies[2].mass",
       "> 0", "-0.3", ""},
      {"a zero force limit", "actuator: {kp: 5.0, force_limit: 4.78}",
       "actuator: {kp: 5.0, force_limit: 0}", "bodies[2].joint.actuator.force_limit", "> 0", "0",
       ""},
      {"a zero joint axis", ff4, "{name: FF4, axis: [0, 0, 0], range_deg: [-20, 20],",
       "bodies[3].joint.axis", "non-zero axis", "[0, 0, 0]", ""},
      {"a parent that is not listed earlier", "    parent: palm\n    pos: [0.033, 0, 0.095]\n",
       "    parent: ffmiddle\n    pos: [0.033, 0, 0.095]\n", "bodies[3].parent",
       "a body listed earlier", "'ffmiddle'", ""},
      {"a repeated joint name", "{name: MF4, axis", "{name: FF4, axis", "bodies[7].joint.name",
       "not used before", "'FF4'", ""},
      {"an unknown side", "side: right\n", "side: middle\n", "side", "right or left", "'middle'",
       ""},
      {"an unknown geom type", "{name: ffknuckle, type: sphere,",
       "{name: ffknuckle, type: cylinder,", "bodies[3].geoms[0].type", "capsule, box, sphere",
       "'cylinder'", ""},
      {"a self-contact with an unknown body", "  - [palm, thmiddle]\n", "  - [palm, thumbnail]\n",
       "self_contacts[11]", "bodies of this hand", "'thumbnail'", ""},
  };
  for (const BadEdit& c : cases) {
    DYNAMIC_SECTION(c.what) {
      EditedSpec f(replace_once(base, c.from, c.to));
      auto e = config_error([&] { load_hand_spec(f.path); });
      check_config_error(e, f.path, c.key, c.expected, c.actual);
      if (!c.line.empty())
        CHECK(e.file() == f.path + ":" + std::to_string(line_of(f.text, c.line)));
    }
  }
  SECTION("not YAML at all") {
    EditedSpec f(replace_once(base, "name: shadow\n", "name: [shadow\n"));
    auto e = config_error([&] { load_hand_spec(f.path); });
    CHECK(e.file().rfind(f.path, 0) == 0);
    CHECK(e.expected() == "valid YAML");
  }
}

TEST_CASE("a missing hand file is an IoError naming it", "[sim][hand_spec]") {
  TempDir dir;
  std::string path = dir.file("no_such_hand.yaml");
  try {
    load_hand_spec(path);
    FAIL("no error");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()).find(path) != std::string::npos);
  }
}
