// The Shadow Hand joint table of the paper (Appendix A.1), written out by hand: the spec the
// generated model is checked against. Not derived from configs/hands/shadow.yaml on purpose.
#pragma once

#include <array>
#include <string>

namespace bidex::test {

struct PaperJoint {
  const char* name;
  double min_deg, max_deg;
  bool actuated;
  double force_limit;  // N m (0 for the coupled distal joints, which have no actuator)
};

// The 24 joints of one hand, in kinematic-tree order.
inline constexpr std::array<PaperJoint, 24> kPaperJoints{{
    {"WR2", -28, 8, true, 2.17},
    {"WR1", -40, 28, true, 4.78},
    {"FF4", -20, 20, true, 0.725},
    {"FF3", -15, 90, true, 0.9},
    {"FF2", 0, 90, true, 0.7245},
    {"FF1", 0, 90, false, 0},
    {"MF4", -20, 20, true, 0.725},
    {"MF3", -15, 90, true, 0.9},
    {"MF2", 0, 90, true, 0.7245},
    {"MF1", 0, 90, false, 0},
    {"RF4", -20, 20, true, 0.725},
    {"RF3", -15, 90, true, 0.9},
    {"RF2", 0, 90, true, 0.7245},
    {"RF1", 0, 90, false, 0},
    {"LF5", 0, 45, true, 0.9},
    {"LF4", -20, 20, true, 0.725},
    {"LF3", -15, 90, true, 0.9},
    {"LF2", 0, 90, true, 0.7245},
    {"LF1", 0, 90, false, 0},
    {"TH5", -60, 60, true, 0.81},
    {"TH4", 0, 70, true, 0.99},
    {"TH3", -12, 12, true, 0.99},
    {"TH2", -30, 30, true, 0.99},
    {"TH1", -15, 90, true, 0.81},
}};

// The four coupled finger pairs: distal joint follows middle joint.
inline constexpr std::array<std::array<const char*, 2>, 4> kPaperCouplings{{
    {"FF1", "FF2"}, {"MF1", "MF2"}, {"RF1", "RF2"}, {"LF1", "LF2"}}};

}  // namespace bidex::test
