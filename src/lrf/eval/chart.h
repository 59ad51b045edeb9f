#pragma once
// Line charts for the HTML report, as inline SVG (no script, no files beside the page): quality against
// wall time of runs that scored themselves as they trained (lrf refine --score-every's curve.csv).
#include <string>
#include <utility>
#include <vector>

namespace lrf {

struct ChartSeries {
  std::string name;
  std::vector<std::pair<double, double>> points;  // (x, y), drawn in this order
};

struct Chart {
  std::string title, x_label, y_label;
  std::vector<ChartSeries> series;
};

// The chart as an <svg> element: axes with round ticks spanning every series' points, one coloured line
// with markers per series, a legend. Throws lrf::Error when no series has a point or a value is not finite.
std::string svg_chart(const Chart& chart);

// The (x, y) pairs of two named columns of a CSV file with a header (rows whose cells are empty are
// skipped); an lrf::Error names the file when a column is missing or a cell is not a number.
std::vector<std::pair<double, double>> read_csv_series(const std::string& path, const std::string& x_column,
                                                       const std::string& y_column);

}  // namespace lrf
