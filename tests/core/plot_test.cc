// SVG plots: round ticks, every panel and series drawn, NaN gaps, escaping.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "core/plot.h"

using namespace bidex;

namespace {
int count(const std::string& s, const std::string& what) {
  int n = 0;
  for (size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}
}  // namespace

TEST_CASE("ticks are round steps covering the range", "[core][plot]") {
  CHECK(plot::ticks(0, 10, 6) == std::vector<double>{0, 2, 4, 6, 8, 10});
  CHECK(plot::ticks(0.13, 0.61, 6) == std::vector<double>{0.2, 0.3, 0.4, 0.5, 0.6});
  CHECK(plot::ticks(-3, 3, 4) == std::vector<double>{-2, 0, 2});
  CHECK(plot::ticks(5, 5) == std::vector<double>{5});
}

TEST_CASE("an SVG holds every panel, series, legend entry and label", "[core][plot]") {
  plot::Panel a;
  a.title = "return <PPO>";
  a.xlabel = "slot-steps";
  a.ylabel = "return";
  plot::Series s1;
  s1.name = "seed 0";
  s1.x = {0, 1, 2, 3, 4};
  s1.y = {1, 2, NAN, 4, 5};  // a gap: two line pieces
  a.series.push_back(s1);
  plot::Panel b;
  b.title = "age";
  plot::Series pts;
  pts.points = true;
  pts.x = {1, 2};
  pts.y = {3, 4};
  pts.labels = {"hand_over", "catch"};
  b.series.push_back(pts);
  const std::string svg = plot::svg({a, b}, 600, 200);
  CHECK(svg.rfind("<svg", 0) == 0);
  CHECK(svg.find("height=\"400\"") != std::string::npos);
  CHECK(svg.find("return &lt;PPO&gt;") != std::string::npos);
  CHECK(svg.find("seed 0") != std::string::npos);
  CHECK(count(svg, "<path") == 1);
  const size_t d = svg.find("<path d=\"");
  const std::string path = svg.substr(d, svg.find('"', d + 9) - d);
  CHECK(count(path, "M") == 2);
  CHECK(count(path, "L") == 2);
  CHECK(count(svg, "<circle") == 2);
  CHECK(svg.find(">hand_over<") != std::string::npos);
  CHECK(svg.rfind("</svg>\n") == svg.size() - 7);
}

TEST_CASE("a panel without data says so instead of failing", "[core][plot]") {
  plot::Panel p;
  p.title = "empty";
  plot::Series s;
  s.x = {0, 1};
  s.y = {NAN, NAN};
  p.series.push_back(s);
  const std::string svg = plot::svg({p});
  CHECK(svg.find("no data yet") != std::string::npos);
  CHECK(count(svg, "<path") == 0);
}

TEST_CASE("a log x axis, x padding, a note, and point labels kept apart and inside",
          "[core][plot]") {
  plot::Panel p;
  p.xlog = true;
  p.xpad = 0.1;
  p.note = "left out: a & b";
  plot::Series pts;
  pts.points = true;
  pts.x = {5, 13, 13, 216, -1};  // x <= 0 has no place on a log axis: left out
  pts.y = {0.5, 0.8, 0.81, 0.2, 0.3};
  pts.labels = {"push_block", "door_a", "door_b", "two_catch_underarm", "never"};
  p.series.push_back(pts);
  const std::string svg = plot::svg({p}, 600, 300);
  CHECK(count(svg, "<circle") == 4);
  CHECK(svg.find(">never<") == std::string::npos);
  for (const char* t : {">5<", ">10<", ">20<", ">50<", ">100<", ">200<"}) {
    INFO(t);
    CHECK(svg.find(t) != std::string::npos);  // ticks 1, 2, 5 x 10^k
  }
  CHECK(svg.find("left out: a &amp; b") != std::string::npos);
  // the circles of 5 and 216 lie inside the padded range, not on the frame (x 70..580)
  const size_t c0 = svg.find("<circle cx=\"");
  const double x0 = std::stod(svg.substr(c0 + 12));
  CHECK(x0 > 90);
  // the <text ...> tag of a label
  auto tag = [&](const std::string& label) {
    const size_t end = svg.find(">" + label + "<");
    REQUIRE(end != std::string::npos);
    const size_t start = svg.rfind("<text", end);
    return svg.substr(start, end - start);
  };
  auto label_y = [&](const std::string& label) {
    const std::string t = tag(label);
    return std::stod(t.substr(t.find(" y=\"") + 4));
  };
  // the two labels at 13 months, 0.01 apart, do not overlap, and keep their points' order:
  // door_b's point is the higher, so is its label (drawn after door_a's, it moves up past it)
  CHECK(std::abs(label_y("door_a") - label_y("door_b")) >= 11);
  CHECK(label_y("door_b") < label_y("door_a"));
  // the label of the rightmost point is drawn to its left, the others to the right
  CHECK(tag("two_catch_underarm").find("text-anchor=\"end\"") != std::string::npos);
  CHECK(tag("door_a").find("text-anchor") == std::string::npos);
}
