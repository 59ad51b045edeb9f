#include "lrf/eval/chart.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "lrf/core/error.h"
#include "lrf/eval/report.h"

namespace lrf {
namespace {

constexpr double kPlotWidth = 406, kHeight = 360, kLeft = 64, kRight = 170, kTop = 36, kBottom = 48;
// About the width of one character of the legend's 11-pixel sans-serif text, so that the legend column
// grows with its longest name instead of cutting it at the picture's edge.
constexpr double kLegendCharWidth = 6.5;
const char* const kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf"};

// Ticks at 1, 2 or 5 times a power of ten, about `count` of them over [lo, hi], and the range they span.
struct Ticks {
  double first = 0, step = 1, lo = 0, hi = 1;
};

Ticks ticks(double lo, double hi, int count) {
  if (hi <= lo) {
    const double pad = lo == 0 ? 1 : std::abs(lo) * 0.05;
    lo -= pad, hi += pad;
  }
  const double raw = (hi - lo) / count, power = std::pow(10.0, std::floor(std::log10(raw)));
  double step = power;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * power >= raw) {
      step = m * power;
      break;
    }
  Ticks t;
  t.step = step;
  t.lo = std::floor(lo / step) * step;
  t.hi = std::ceil(hi / step) * step;
  t.first = t.lo;
  return t;
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", std::abs(v) < 1e-12 ? 0.0 : v);
  return buf;
}

}  // namespace

std::string svg_chart(const Chart& chart) {
  double x_lo = INFINITY, x_hi = -INFINITY, y_lo = INFINITY, y_hi = -INFINITY;
  for (const auto& s : chart.series) {
    for (const auto& [x, y] : s.points) {
      if (!std::isfinite(x) || !std::isfinite(y)) fail("chart '" + chart.title + "': " + s.name + " has a value that is not finite");
      x_lo = std::min(x_lo, x), x_hi = std::max(x_hi, x), y_lo = std::min(y_lo, y), y_hi = std::max(y_hi, y);
    }
  }
  if (!std::isfinite(x_lo)) fail("chart '" + chart.title + "': no points to draw");
  const Ticks tx = ticks(x_lo, x_hi, 6), ty = ticks(y_lo, y_hi, 5);
  size_t longest_name = 0;
  for (const auto& s : chart.series) longest_name = std::max(longest_name, s.name.size());
  const double right = std::max(kRight, 46 + kLegendCharWidth * static_cast<double>(longest_name));
  const double width = kLeft + kPlotWidth + right;
  const double pw = kPlotWidth, ph = kHeight - kTop - kBottom;
  auto px = [&](double x) { return kLeft + (x - tx.lo) / (tx.hi - tx.lo) * pw; };
  auto py = [&](double y) { return kTop + ph - (y - ty.lo) / (ty.hi - ty.lo) * ph; };
  std::ostringstream svg;
  svg.precision(5);
  svg << "<svg class=\"chart\" xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 " << width << " " << kHeight
      << "\" width=\"" << width << "\" height=\"" << kHeight << "\" role=\"img\" aria-label=\""
      << html_escape(chart.title) << "\">\n";
  svg << "<text x=\"" << kLeft << "\" y=\"20\" font-size=\"14\" font-weight=\"bold\">" << html_escape(chart.title)
      << "</text>\n";
  svg << "<g font-size=\"11\" fill=\"#333\">\n";
  for (double x = tx.first; x <= tx.hi + tx.step * 1e-6; x += tx.step) {
    svg << "<line x1=\"" << px(x) << "\" y1=\"" << kTop << "\" x2=\"" << px(x) << "\" y2=\"" << kTop + ph
        << "\" stroke=\"#e4e4e4\"/><text x=\"" << px(x) << "\" y=\"" << kTop + ph + 16
        << "\" text-anchor=\"middle\">" << number(x) << "</text>\n";
  }
  for (double y = ty.first; y <= ty.hi + ty.step * 1e-6; y += ty.step) {
    svg << "<line x1=\"" << kLeft << "\" y1=\"" << py(y) << "\" x2=\"" << kLeft + pw << "\" y2=\"" << py(y)
        << "\" stroke=\"#e4e4e4\"/><text x=\"" << kLeft - 6 << "\" y=\"" << py(y) + 4 << "\" text-anchor=\"end\">"
        << number(y) << "</text>\n";
  }
  svg << "<rect x=\"" << kLeft << "\" y=\"" << kTop << "\" width=\"" << pw << "\" height=\"" << ph
      << "\" fill=\"none\" stroke=\"#888\"/>\n";
  svg << "<text x=\"" << kLeft + pw / 2 << "\" y=\"" << kHeight - 10 << "\" text-anchor=\"middle\">"
      << html_escape(chart.x_label) << "</text>\n";
  svg << "<text transform=\"translate(16 " << kTop + ph / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
      << html_escape(chart.y_label) << "</text>\n</g>\n";
  for (size_t k = 0; k < chart.series.size(); ++k) {
    const auto& s = chart.series[k];
    const char* colour = kColours[k % (sizeof kColours / sizeof kColours[0])];
    svg << "<g stroke=\"" << colour << "\" fill=\"" << colour << "\">\n<polyline fill=\"none\" stroke-width=\"2\" points=\"";
    for (const auto& [x, y] : s.points) svg << px(x) << "," << py(y) << " ";
    svg << "\"/>\n";
    for (const auto& [x, y] : s.points) svg << "<circle cx=\"" << px(x) << "\" cy=\"" << py(y) << "\" r=\"2.5\"/>";
    const double ly = kTop + 10 + 18 * static_cast<double>(k);
    svg << "\n<line x1=\"" << kLeft + pw + 12 << "\" y1=\"" << ly << "\" x2=\"" << kLeft + pw + 32 << "\" y2=\"" << ly
        << "\" stroke-width=\"2\"/><text x=\"" << kLeft + pw + 38 << "\" y=\"" << ly + 4
        << "\" font-size=\"11\" stroke=\"none\" fill=\"#333\">" << html_escape(s.name) << "</text>\n</g>\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

std::vector<std::pair<double, double>> read_csv_series(const std::string& path, const std::string& x_column,
                                                       const std::string& y_column) {
  std::ifstream in(path);
  if (!in) fail(path, "cannot be read");
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  std::istringstream header(line);
  for (std::string cell; std::getline(header, cell, ',');) names.push_back(cell);
  auto column = [&](const std::string& name) {
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) fail(path, "no column '" + name + "' in its header");
    return static_cast<size_t>(it - names.begin());
  };
  const size_t xc = column(x_column), yc = column(y_column);
  std::vector<std::pair<double, double>> points;
  for (int row = 2; std::getline(in, line); ++row) {
    if (line.empty()) continue;
    std::vector<std::string> cells;
    std::istringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
    if (xc >= cells.size() || yc >= cells.size() || cells[xc].empty() || cells[yc].empty()) continue;
    auto value = [&](const std::string& cell) {
      size_t used = 0;
      double v = 0;
      try {
        v = std::stod(cell, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != cell.size()) fail(path, "line " + std::to_string(row) + ": '" + cell + "' is not a number");
      return v;
    };
    points.emplace_back(value(cells[xc]), value(cells[yc]));
  }
  return points;
}

}  // namespace lrf
