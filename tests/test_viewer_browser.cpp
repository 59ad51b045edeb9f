// The viewer in a real browser: `lrf serve` on a tiny field, Debian's headless Chromium opens the page,
// the test drags the camera and switches views through the DevTools protocol, and checks that new,
// different frames arrive, in two tabs at once. The screenshots are kept in build/test_artifacts/.
#include <filesystem>
#include <regex>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "chromium_cdp.h"
#include "child_process.h"
#include "field_helpers.h"
#include "lrf/core/atomic_file.h"
#include "test_helpers.h"

namespace fs = std::filesystem;
using lrf::test::Chromium;

namespace {

std::string base64_decode(const std::string& in) {
  static const std::string chars = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  int value = 0, bits = -8;
  for (char c : in) {
    const size_t d = chars.find(c);
    if (d == std::string::npos) break;  // '=' padding ends the data
    value = (value << 6) + static_cast<int>(d);
    bits += 6;
    if (bits >= 0) {
      out.push_back(static_cast<char>((value >> bits) & 0xff));
      bits -= 8;
    }
  }
  return out;
}

cv::Mat screenshot(Chromium& browser, const std::string& session, const std::string& path) {
  const std::string png = base64_decode(browser.call("Page.captureScreenshot", {{"format", "png"}}, session)["data"]);
  lrf::write_file_atomic(path, png);
  return cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_COLOR);
}

void drag(Chromium& browser, const std::string& session, double x, double y, double dx, double dy) {
  browser.call("Input.dispatchMouseEvent", {{"type", "mousePressed"}, {"x", x}, {"y", y}, {"button", "left"},
                                            {"buttons", 1}, {"clickCount", 1}}, session);
  for (int k = 1; k <= 8; ++k)
    browser.call("Input.dispatchMouseEvent", {{"type", "mouseMoved"}, {"x", x + dx * k / 8}, {"y", y + dy * k / 8},
                                              {"button", "left"}, {"buttons", 1}}, session);
  browser.call("Input.dispatchMouseEvent", {{"type", "mouseReleased"}, {"x", x + dx}, {"y", y + dy}, {"button", "left"},
                                            {"buttons", 0}, {"clickCount", 1}}, session);
}

// The viewer's state after the camera settled: the shown frame is a full-resolution one of the current pose.
const char* kSettled = "lrfViewer.ready && lrfViewer.fullFramesShown > 0 && lrfViewer.lastFull && "
                       "lrfViewer.shownVersion === lrfViewer.poseVersion";

}  // namespace

TEST(ViewerBrowser, DragAndSwitchViewsInTwoTabs) {
  const std::string chromium = lrf::test::find_chromium();
  if (chromium.empty()) GTEST_SKIP() << "Chromium is not installed (Debian: apt-get install chromium; scripts/install-deps.sh does)";
  const std::string field = lrf::test::tiny_field("rgb");
  lrf::test::TempDir tmp("viewer_browser");
  const fs::path artifacts = fs::path(LRF_BINARY).parent_path() / "test_artifacts";
  fs::create_directories(artifacts);

  lrf::test::ChildProcess server({LRF_BINARY, "--threads", "2", "serve", field, "--port", "0"}, true, tmp / "serve.log");
  const std::string line = server.read_line(60);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(line, m, std::regex("http://127\\.0\\.0\\.1:(\\d+)/"))) << "lrf serve printed: " << line;
  const std::string url = m[0];

  Chromium browser(chromium, tmp / "profile");
  const std::string tab = browser.open_page(url);
  ASSERT_TRUE(browser.wait_for(tab, kSettled, 60)) << browser.eval(tab, "JSON.stringify(window.lrfViewer)").dump();
  const auto before = browser.eval(tab, "lrfViewer");
  EXPECT_EQ(before["errors"], 0) << before.dump();
  EXPECT_EQ(before["lastSize"], nlohmann::json({64, 48}));
  const cv::Mat shot_before = screenshot(browser, tab, (artifacts / "viewer_before.png").string());

  // Drag across the middle of the frame: the camera orbits, new frames come, the settled one differs.
  const auto centre = browser.eval(tab, "(() => { const r = document.getElementById('overlay').getBoundingClientRect(); "
                                        "return [r.left + r.width / 2, r.top + r.height / 2]; })()");
  drag(browser, tab, centre[0].get<double>(), centre[1].get<double>(), 300, 80);
  ASSERT_TRUE(browser.wait_for(tab, std::string(kSettled) + " && lrfViewer.lastSeq > " + before["lastSeq"].dump(), 60));
  const auto after = browser.eval(tab, "lrfViewer");
  EXPECT_GT(after["poseVersion"].get<int>(), before["poseVersion"].get<int>());
  EXPECT_GT(after["framesShown"].get<int>(), before["framesShown"].get<int>());
  EXPECT_NE(after["checksum"], before["checksum"]) << "the frame after the drag should differ";
  EXPECT_EQ(after["errors"], 0) << after.dump();
  // Small frames while moving are expected but not asserted: a browser stalled for 250 ms under load
  // would rightly ask for the full frame at once.
  std::printf("viewer: after the drag, %d small and %d full frames shown in all\n", after["lowFramesShown"].get<int>(),
              after["fullFramesShown"].get<int>());
  const cv::Mat shot_after = screenshot(browser, tab, (artifacts / "viewer_after.png").string());
  ASSERT_EQ(shot_before.size(), shot_after.size());
  EXPECT_GT(cv::norm(shot_before, shot_after, cv::NORM_L1), 0.0);
  const std::string fps = browser.eval(tab, "document.getElementById('fps').textContent");
  EXPECT_TRUE(std::regex_match(fps, std::regex("FPS \\d+"))) << fps;
  const std::string timing = browser.eval(tab, "document.getElementById('timing').textContent");
  EXPECT_NE(timing.find("render"), std::string::npos) << timing;

  // Another test view from the list: its own pose, a different frame.
  const auto views = browser.eval(tab, "Array.from(document.querySelectorAll('#views option')).map(o => o.value)");
  ASSERT_GE(views.size(), 2u);
  const int shown = after["lastSeq"];
  browser.eval(tab, "(() => { const s = document.getElementById('views'); s.value = '" + views[1].get<std::string>() +
                        "'; s.dispatchEvent(new Event('change')); })()");
  ASSERT_TRUE(browser.wait_for(tab, std::string(kSettled) + " && lrfViewer.lastSeq > " + std::to_string(shown), 60));
  const auto switched = browser.eval(tab, "lrfViewer");
  EXPECT_NE(switched["checksum"], after["checksum"]);

  // A second tab: both get frames of their own while both cameras move.
  const std::string tab2 = browser.open_page(url);
  ASSERT_TRUE(browser.wait_for(tab2, kSettled, 60)) << browser.eval(tab2, "JSON.stringify(window.lrfViewer)").dump();
  const auto one = browser.eval(tab, "lrfViewer"), two = browser.eval(tab2, "lrfViewer");
  drag(browser, tab, centre[0].get<double>(), centre[1].get<double>(), -80, 0);
  drag(browser, tab2, centre[0].get<double>(), centre[1].get<double>(), 0, 60);
  EXPECT_TRUE(browser.wait_for(tab, std::string(kSettled) + " && lrfViewer.lastSeq > " + one["lastSeq"].dump(), 60));
  EXPECT_TRUE(browser.wait_for(tab2, std::string(kSettled) + " && lrfViewer.lastSeq > " + two["lastSeq"].dump(), 60));
  EXPECT_NE(browser.eval(tab2, "lrfViewer.checksum"), two["checksum"]);
  EXPECT_EQ(browser.eval(tab2, "lrfViewer.errors"), 0);
  screenshot(browser, tab2, (artifacts / "viewer_second_tab.png").string());

  // A malformed frame request from the page gets 400, and the viewer keeps working afterwards.
  EXPECT_EQ(browser.eval(tab, "fetch('/api/frame?client=x&seq=1&w=NaN').then(r => r.status)"), 400);
  const int last = browser.eval(tab, "lrfViewer.lastSeq");
  drag(browser, tab, centre[0].get<double>(), centre[1].get<double>(), 30, 30);
  EXPECT_TRUE(browser.wait_for(tab, std::string(kSettled) + " && lrfViewer.lastSeq > " + std::to_string(last), 60));
  EXPECT_EQ(server.stop(), 0) << "lrf serve exits cleanly on SIGTERM";
}
