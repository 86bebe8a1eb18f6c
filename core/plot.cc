#include "core/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace bidex::plot {

namespace {

const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                         "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};

std::string num(double v) {
  char buf[32];
  const double a = std::abs(v);
  if (v == 0) return "0";
  if (a >= 1e6 || a < 1e-3) std::snprintf(buf, sizeof buf, "%.3g", v);
  else std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '&') out += "&amp;";
    else if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '"') out += "&quot;";
    else out += c;
  }
  return out;
}

std::string fmt(const char* f, double a, double b) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

}  // namespace

std::vector<double> ticks(double lo, double hi, int target) {
  if (!(hi > lo)) return {lo};
  const double raw = (hi - lo) / std::max(1, target - 1);
  const int e = static_cast<int>(std::floor(std::log10(raw)));
  const double mag = std::pow(10.0, std::abs(e));
  // step = m 10^e; a tick is k m 10^e, computed as an integer scaled once so 0.3 prints as 0.3
  int m = 10;
  for (int c : {1, 2, 5, 10})
    if ((e < 0 ? c / mag : c * mag) >= raw) {
      m = c;
      break;
    }
  auto value = [&](long long km) { return e < 0 ? km / mag : km * mag; };
  const double step = value(m);
  std::vector<double> out;
  for (long long k = static_cast<long long>(std::ceil(lo / step)); value(k * m) <= hi + 1e-9 * step;
       ++k)
    out.push_back(value(k * m));
  return out;
}

std::string svg(const std::vector<Panel>& panels, int width, int panel_height) {
  const int height = panel_height * static_cast<int>(std::max<size_t>(panels.size(), 1));
  std::string s;
  s += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(width) +
       "\" height=\"" + std::to_string(height) + "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  s += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  const double ml = 70, mr = 20, mt = 30, mb = 45;
  for (size_t p = 0; p < panels.size(); ++p) {
    const Panel& pan = panels[p];
    const double top = p * panel_height + mt, bottom = (p + 1) * panel_height - mb;
    const double left = ml, right = width - mr;
    // data range (of log10 x on a log axis)
    auto tx = [&](double x) { return pan.xlog ? (x > 0 ? std::log10(x) : NAN) : x; };
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (auto& se : pan.series)
      for (size_t i = 0; i < se.x.size() && i < se.y.size(); ++i) {
        if (!std::isfinite(tx(se.x[i])) || !std::isfinite(se.y[i])) continue;
        x0 = std::min(x0, tx(se.x[i]));
        x1 = std::max(x1, tx(se.x[i]));
        y0 = std::min(y0, se.y[i]);
        y1 = std::max(y1, se.y[i]);
      }
    const bool empty = !std::isfinite(x0);
    if (empty) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
    if (x1 <= x0) x1 = x0 + 1;
    if (pan.xpad > 0) {
      const double pad = pan.xpad * (x1 - x0);
      x0 -= pad;
      x1 += pad;
    }
    if (y1 <= y0) {
      const double pad = std::max(std::abs(y0) * 0.1, 1e-3);
      y0 -= pad;
      y1 += pad;
    } else {
      const double pad = 0.05 * (y1 - y0);
      y0 -= pad;
      y1 += pad;
    }
    // X maps an axis value (log10 x on a log axis), PX a data x
    auto X = [&](double x) { return left + (x - x0) / (x1 - x0) * (right - left); };
    auto PX = [&](double x) { return X(tx(x)); };
    auto Y = [&](double y) { return bottom - (y - y0) / (y1 - y0) * (bottom - top); };
    s += "<text x=\"" + num((left + right) / 2) + "\" y=\"" + num(top - 10) +
         "\" text-anchor=\"middle\" font-size=\"14\">" + escape(pan.title) + "</text>\n";
    s += "<rect x=\"" + num(left) + "\" y=\"" + num(top) + "\" width=\"" + num(right - left) +
         "\" height=\"" + num(bottom - top) + "\" fill=\"none\" stroke=\"#444\"/>\n";
    std::vector<double> xticks;
    if (pan.xlog) {
      for (int e = static_cast<int>(std::floor(x0)); e <= static_cast<int>(std::ceil(x1)); ++e)
        for (double m : {1.0, 2.0, 5.0}) {
          const double t = m * std::pow(10.0, e);
          if (std::log10(t) >= x0 - 1e-9 && std::log10(t) <= x1 + 1e-9) xticks.push_back(t);
        }
    } else {
      xticks = ticks(x0, x1);
    }
    for (double t : xticks) {
      const double px = PX(t);
      s += "<line x1=\"" + num(px) + "\" y1=\"" + num(top) + "\" x2=\"" + num(px) + "\" y2=\"" +
           num(bottom) + "\" stroke=\"#e5e5e5\"/>\n";
      s += "<text x=\"" + num(px) + "\" y=\"" + num(bottom + 15) +
           "\" text-anchor=\"middle\">" + num(t) + "</text>\n";
    }
    for (double t : ticks(y0, y1)) {
      const double py = Y(t);
      s += "<line x1=\"" + num(left) + "\" y1=\"" + num(py) + "\" x2=\"" + num(right) +
           "\" y2=\"" + num(py) + "\" stroke=\"#e5e5e5\"/>\n";
      s += "<text x=\"" + num(left - 5) + "\" y=\"" + num(py + 4) + "\" text-anchor=\"end\">" +
           num(t) + "</text>\n";
    }
    s += "<text x=\"" + num((left + right) / 2) + "\" y=\"" + num(bottom + 35) +
         "\" text-anchor=\"middle\">" + escape(pan.xlabel) + "</text>\n";
    s += "<text transform=\"translate(" + num(left - 50) + "," + num((top + bottom) / 2) +
         ") rotate(-90)\" text-anchor=\"middle\">" + escape(pan.ylabel) + "</text>\n";
    if (!pan.note.empty())
      s += "<text x=\"" + num(left + 6) + "\" y=\"" + num(bottom - 6) +
           "\" font-size=\"10\" fill=\"#666\">" + escape(pan.note) + "</text>\n";
    if (empty)
      s += "<text x=\"" + num((left + right) / 2) + "\" y=\"" + num((top + bottom) / 2) +
           "\" text-anchor=\"middle\" fill=\"#888\">no data yet</text>\n";
    int legend = 0;
    std::vector<std::pair<double, double>> placed;  // point labels drawn so far (x, y)
    for (size_t k = 0; k < pan.series.size(); ++k) {
      const Series& se = pan.series[k];
      const std::string color = kColors[k % (sizeof kColors / sizeof *kColors)];
      if (se.points) {
        for (size_t i = 0; i < se.x.size() && i < se.y.size(); ++i) {
          if (!std::isfinite(tx(se.x[i])) || !std::isfinite(se.y[i])) continue;
          s += "<circle cx=\"" + num(PX(se.x[i])) + "\" cy=\"" + num(Y(se.y[i])) +
               "\" r=\"4\" fill=\"" + color + "\"/>\n";
          if (i < se.labels.size() && !se.labels[i].empty()) {
            // right of the point, or left of it where the text would leave the panel; past
            // the labels already placed at the same spot rather than over them, on the side
            // where its point lies (above the first one it meets when it would stand higher,
            // else below), so that the labels keep their points' order
            double lx = PX(se.x[i]) + 6, ly = Y(se.y[i]) - 4;
            const bool flip = lx + 6.0 * se.labels[i].size() > width;  // ~6 px a character
            if (flip) lx = PX(se.x[i]) - 6;
            for (bool moved = true, up = false, chosen = false; moved;) {
              moved = false;
              for (auto& [px, py] : placed)
                if (std::abs(px - lx) < 1 && std::abs(py - ly) < 11) {
                  if (!chosen) {
                    up = ly < py;
                    chosen = true;
                  }
                  ly = up ? py - 11 : py + 11;  // strictly one way: the loop ends
                  moved = true;
                }
            }
            placed.emplace_back(lx, ly);
            s += "<text x=\"" + num(lx) + "\" y=\"" + num(ly) +
                 (flip ? "\" text-anchor=\"end" : "") + "\" font-size=\"10\">" +
                 escape(se.labels[i]) + "</text>\n";
          }
        }
      } else {
        std::string d;
        bool pen = false;
        for (size_t i = 0; i < se.x.size() && i < se.y.size(); ++i) {
          if (!std::isfinite(tx(se.x[i])) || !std::isfinite(se.y[i])) {
            pen = false;
            continue;
          }
          d += fmt(pen ? "L%.1f %.1f " : "M%.1f %.1f ", PX(se.x[i]), Y(se.y[i]));
          pen = true;
        }
        if (!d.empty())
          s += "<path d=\"" + d + "\" fill=\"none\" stroke=\"" + color +
               "\" stroke-width=\"1.5\"/>\n";
      }
      if (!se.name.empty()) {
        const double ly = top + 14 + 16 * legend++;
        s += "<rect x=\"" + num(left + 8) + "\" y=\"" + num(ly - 9) +
             "\" width=\"12\" height=\"3\" fill=\"" + color + "\"/>\n";
        s += "<text x=\"" + num(left + 25) + "\" y=\"" + num(ly - 4) + "\">" + escape(se.name) +
             "</text>\n";
      }
    }
  }
  s += "</svg>\n";
  return s;
}

}  // namespace bidex::plot
