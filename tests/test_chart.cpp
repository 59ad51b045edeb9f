// The report's line charts (eval/chart.h): one line per series over axes that span every point, and the
// CSV columns they are read from.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "lrf/eval/chart.h"
#include "test_helpers.h"

namespace {

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

}  // namespace

TEST(Chart, DrawsOneLinePerSeriesWithItsPointsAndLegend) {
  lrf::Chart chart;
  chart.title = "PSNR <against> time";
  chart.x_label = "s";
  chart.y_label = "dB";
  chart.series = {{"old & slow", {{0, 20}, {100, 21.5}, {600, 22.4}}}, {"new", {{0, 20}, {50, 22.1}}}};
  const std::string svg = lrf::svg_chart(chart);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_EQ(count(svg, "<polyline"), 2u);
  EXPECT_EQ(count(svg, "<circle"), 5u);
  EXPECT_NE(svg.find("old &amp; slow"), std::string::npos);  // names and title escaped
  EXPECT_NE(svg.find("PSNR &lt;against&gt; time"), std::string::npos);
  // The axes span the points on round ticks: 0..600 s in steps of 100, 20..22.4 dB in steps of 0.5.
  EXPECT_NE(svg.find(">600</text>"), std::string::npos);
  EXPECT_NE(svg.find(">22.5</text>"), std::string::npos);
  EXPECT_NE(svg.find(">20</text>"), std::string::npos);
  EXPECT_EQ(svg.find(">700</text>"), std::string::npos);
  // The first series' last point sits at the plot's right edge, x = 64 + the plot's 406 pixels; short names
  // leave the picture 640 pixels wide.
  EXPECT_NE(svg.find("470,"), std::string::npos);
  EXPECT_NE(svg.find("width=\"640\""), std::string::npos);
  // A long name widens the legend's column instead of running off the picture (it was cut at 640 px).
  lrf::Chart long_names = chart;
  long_names.series[0].name = "earlier defaults (2000 steps, densified until 1000)";  // 51 characters
  const std::string wide = lrf::svg_chart(long_names);
  EXPECT_NE(wide.find("width=\"847.5\""), std::string::npos) << wide.substr(0, 200);  // 64 + 406 + 46 + 6.5 x 51
  EXPECT_NE(wide.find("470,"), std::string::npos);

  chart.series[1].points.push_back({60, std::nan("")});
  EXPECT_NE(lrf::test::error_of([&] { lrf::svg_chart(chart); }).find("not finite"), std::string::npos);
  lrf::Chart empty;
  empty.series = {{"none", {}}};
  EXPECT_NE(lrf::test::error_of([&] { lrf::svg_chart(empty); }).find("no points"), std::string::npos);
}

TEST(Chart, ReadsTwoColumnsOfACsvAndNamesTheFileOnErrors) {
  lrf::test::TempDir dir("chart");
  const std::string path = dir / "curve.csv";
  {
    std::ofstream out(path);
    out << "step,seconds,psnr,ms_ssim\n10,5.5,20.25,\n20,11,21.5,0.8\n\n30,16.5,,0.9\n";
  }
  const auto points = lrf::read_csv_series(path, "seconds", "psnr");
  ASSERT_EQ(points.size(), 2u);  // the row with an empty PSNR is skipped
  EXPECT_EQ(points[0], std::make_pair(5.5, 20.25));
  EXPECT_EQ(points[1], std::make_pair(11.0, 21.5));
  EXPECT_EQ(lrf::read_csv_series(path, "step", "ms_ssim").size(), 2u);
  EXPECT_NE(lrf::test::error_of([&] { lrf::read_csv_series(path, "seconds", "flip"); }).find("no column 'flip'"),
            std::string::npos);
  {
    std::ofstream out(path, std::ios::app);
    out << "40,22x,22.5,0.9\n";
  }
  const std::string bad = lrf::test::error_of([&] { lrf::read_csv_series(path, "seconds", "psnr"); });
  EXPECT_NE(bad.find(path), std::string::npos);
  EXPECT_NE(bad.find("'22x' is not a number"), std::string::npos);
  EXPECT_NE(lrf::test::error_of([&] { lrf::read_csv_series(dir / "missing.csv", "a", "b"); }).find("cannot be read"),
            std::string::npos);
}
