// Plots as SVG text: panels of line (or point) series with axes, ticks, labels and a legend, for
// learning curves and reports. Plain text, no plotting library: an SVG opens in any browser and
// diffs in git. Missing values (NaN) break a line.
#pragma once

#include <string>
#include <vector>

namespace bidex::plot {

struct Series {
  std::string name;             // legend entry (empty: none)
  std::vector<double> x, y;     // same length; NaN y values are gaps
  bool points = false;          // markers instead of a line
  std::vector<std::string> labels;  // optional text beside each point (points only)
};

struct Panel {
  std::string title, xlabel, ylabel;
  std::vector<Series> series;
  bool xlog = false;   // logarithmic x axis (ticks 1, 2, 5 x 10^k); x <= 0 counts as missing
  double xpad = 0;     // blank margin on both sides of the x range, as a fraction of it
  std::string note;    // a line of small grey text at the panel's lower left (empty: none)
};

// Panels stacked vertically, each `panel_height` pixels high and `width` wide.
std::string svg(const std::vector<Panel>& panels, int width = 720, int panel_height = 300);

// Round tick values covering [lo, hi] (about `target` of them): steps of 1, 2 or 5 x 10^k.
std::vector<double> ticks(double lo, double hi, int target = 6);

}  // namespace bidex::plot
