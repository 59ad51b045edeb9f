// The compare report's tables fit a 1280-pixel-wide window: measured in Debian's headless Chromium on a
// report with compare's twelve summary columns and its efficiency table, filled with the longest values
// they hold (all eight methods, thousands of seconds and megabytes, the latent-refined row's fitted_to).
#include <filesystem>

#include <gtest/gtest.h>

#include "chromium_cdp.h"
#include "lrf/eval/report.h"
#include "lrf/core/atomic_file.h"
#include "test_helpers.h"

namespace {

lrf::ReportSpec wide_report() {
  lrf::ReportSpec spec;
  spec.title = "lrf compare: llff-fern";
  spec.summary_header = {"method", "psnr", "ssim", "ms_ssim", "flip", "lpips", "train_seconds", "gaussians",
                         "storage_mb", "render_fps", "decode_fps", "peak_memory_mb"};
  spec.summary_better = {lrf::Better::none,  lrf::Better::higher, lrf::Better::higher, lrf::Better::higher,
                         lrf::Better::lower, lrf::Better::lower,  lrf::Better::lower,  lrf::Better::none,
                         lrf::Better::lower, lrf::Better::higher, lrf::Better::higher, lrf::Better::lower};
  lrf::ReportTable efficiency;
  efficiency.title = "Efficiency";
  efficiency.header = {"method", "fitted_to", "train_seconds", "peak_memory_mb", "storage_mb", "gaussians",
                       "render_fps", "decode_fps", "psnr", "ssim"};
  for (const char* method : {"rgb", "rgb-mip", "rgb/8", "rgb/8-mip", "latent", "latent-refined", "latent-nerf",
                             "feature-gs"}) {
    spec.summary_rows.push_back({method, 23.0412, 0.7341, 0.9172, 0.1643, 0.2871, 12345.6, 1234567.0, 291.45,
                                 123.45, 12.345, 12345.6});
    efficiency.rows.push_back({method, "63x47x32 latents, then 504x376 RGB through the decoder", 12345.6, 12345.6,
                               291.45, 1234567.0, 123.45, 12.345, 23.0412, 0.7341});
  }
  spec.tables.push_back(efficiency);
  spec.notes = {"A note."};
  return spec;
}

TEST(ReportLayout, TablesFitA1280PixelWindow) {
  const std::string chromium = lrf::test::find_chromium();
  if (chromium.empty()) GTEST_SKIP() << "Chromium is not installed (Debian: apt-get install chromium)";
  lrf::test::TempDir tmp("report_layout");
  const std::string page = tmp / "report.html";
  lrf::write_html_report(page, wide_report());
  lrf::test::Chromium browser(chromium, tmp / "profile");
  const std::string tab = browser.open_page("file://" + page);
  browser.call("Emulation.setDeviceMetricsOverride",
               {{"width", 1280}, {"height", 800}, {"deviceScaleFactor", 1}, {"mobile", false}}, tab);
  // The report's own document, not the about:blank the tab opened with (complete at once, which let the
  // query below run before the report had loaded when the machine was busy).
  ASSERT_TRUE(browser.wait_for(
      tab, "location.protocol === 'file:' && document.readyState === 'complete' && innerWidth === 1280", 30));
  // How far each table reaches beyond its box (scrolls), and the page beyond the window.
  const auto overflow = browser.eval(tab, "Array.from(document.querySelectorAll('.table-wrap'))"
                                          ".map(w => w.scrollWidth - w.clientWidth)");
  ASSERT_EQ(overflow.size(), 2u);
  EXPECT_LE(overflow[0].get<int>(), 0) << "the summary table scrolls at 1280 px";
  EXPECT_LE(overflow[1].get<int>(), 0) << "the efficiency table scrolls at 1280 px";
  EXPECT_LE(browser.eval(tab, "document.documentElement.scrollWidth").get<int>(), 1280);
}

}  // namespace
