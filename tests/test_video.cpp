// MP4 writing (H.264 through OpenCV's FFmpeg) and lrf render --path end to end on tiny fields.
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "field_helpers.h"
#include "lrf/core/error.h"
#include "lrf/video/mp4_writer.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

// A smooth, moving RGB test pattern (8-bit).
cv::Mat pattern(int width, int height, int k) {
  cv::Mat m(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      m.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uchar>((4 * x + 8 * k) % 256), static_cast<uchar>(3 * y + 20),
                                        static_cast<uchar>(128 + 60 * ((x / 16 + k) % 2)));
  return m;
}

struct Video {
  std::vector<cv::Mat> frames;  // RGB
  std::string fourcc;
};

Video read_video(const std::string& path) {
  cv::VideoCapture cap(path, cv::CAP_FFMPEG);
  Video v;
  if (!cap.isOpened()) return v;
  const int code = static_cast<int>(cap.get(cv::CAP_PROP_FOURCC));
  for (int i = 0; i < 4; ++i) v.fourcc += static_cast<char>((code >> (8 * i)) & 0xff);
  cv::Mat bgr;
  while (cap.read(bgr)) {
    cv::Mat rgb;
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
    v.frames.push_back(rgb.clone());
  }
  return v;
}

double mean_abs_diff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  const cv::Scalar s = cv::mean(d);
  return (s[0] + s[1] + s[2]) / 3.0;
}

bool only_file_in(const std::string& dir, const std::string& name) {
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename() != name) return false;
  return true;
}

}  // namespace

TEST(Video, WritesH264ThatReadsBack) {
  lrf::test::TempDir tmp("video_write");
  const std::string path = tmp / "v.mp4";
  {
    lrf::video::Mp4Writer w(path, 64, 48, 12);
    EXPECT_EQ(w.codec(), "H.264 (avc1)") << "Debian's FFmpeg has libx264";
    for (int k = 0; k < 10; ++k) w.write(pattern(64, 48, k));
    EXPECT_FALSE(fs::exists(path)) << "the video appears only when finished";
    w.finish();
  }
  ASSERT_TRUE(fs::exists(path));
  EXPECT_TRUE(only_file_in(tmp.str(), "v.mp4")) << "no temporary file left";
  const Video v = read_video(path);
  EXPECT_EQ(v.fourcc, "avc1");
  ASSERT_EQ(v.frames.size(), 10u);
  for (int k = 0; k < 10; ++k) {
    ASSERT_EQ(v.frames[static_cast<size_t>(k)].size(), cv::Size(64, 48));
    // Lossy, 4:2:0 chroma: a few levels of error on this pattern; a wrong frame order or a colour swap
    // costs tens of levels (the pattern shifts by 8 levels per frame, red and blue differ by ~100).
    EXPECT_LT(mean_abs_diff(v.frames[static_cast<size_t>(k)], pattern(64, 48, k)), 6.0) << k;
  }
}

TEST(Video, OddSizesArePaddedAndErrorsLeaveNothing) {
  lrf::test::TempDir tmp("video_errors");
  {
    lrf::video::Mp4Writer w(tmp / "odd.mp4", 63, 47, 30);
    for (int k = 0; k < 3; ++k) w.write(pattern(63, 47, k));
    EXPECT_THROW(w.write(pattern(64, 48, 0)), lrf::Error);
    w.finish();
  }
  const Video v = read_video(tmp / "odd.mp4");
  ASSERT_EQ(v.frames.size(), 3u);
  EXPECT_EQ(v.frames[0].size(), cv::Size(64, 48));
  EXPECT_LT(mean_abs_diff(v.frames[1](cv::Rect(0, 0, 63, 47)), pattern(63, 47, 1)), 6.0);

  // Abandoned (an exception while rendering): neither the video nor its temporary file remains.
  { lrf::video::Mp4Writer w(tmp / "abandoned.mp4", 32, 32, 30); w.write(pattern(32, 32, 0)); }
  EXPECT_FALSE(fs::exists(tmp / "abandoned.mp4"));
  EXPECT_TRUE(only_file_in(tmp.str(), "odd.mp4"));
  EXPECT_NE(lrf::test::error_of([&] { lrf::video::Mp4Writer w(tmp / "empty.mp4", 32, 32, 30); w.finish(); }).find("no frames"),
            std::string::npos);
  EXPECT_NE(lrf::test::error_of([&] { lrf::video::Mp4Writer(tmp / "missing/v.mp4", 32, 32, 30); }).find("does not exist"),
            std::string::npos);
  EXPECT_NE(lrf::test::error_of([&] { lrf::video::Mp4Writer(tmp / "v.mp4", 32, 32, 0); }).find("frame rate"),
            std::string::npos);
  EXPECT_TRUE(only_file_in(tmp.str(), "odd.mp4"));
}

TEST(Video, RenderPathCliRgb) {
  lrf::test::TempDir tmp("video_cli_rgb");
  const std::string field = lrf::test::tiny_field("rgb");
  auto r = lrf::test::run_lrf("--threads 2 render '" + field + "' --path spiral --frames 6 --fps 10 --video '" + tmp.str() +
                              "/s.mp4' --frames-dir '" + tmp.str() + "/frames'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("frames/s"), std::string::npos) << r.output;
  const Video v = read_video(tmp / "s.mp4");
  ASSERT_EQ(v.frames.size(), 6u);
  EXPECT_EQ(v.fourcc, "avc1");
  std::vector<cv::Mat> pngs;
  for (int k = 0; k < 6; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "frames/frame_%04d.png", k);
    cv::Mat png = cv::imread(tmp / name);
    ASSERT_FALSE(png.empty()) << name;
    cv::cvtColor(png, png, cv::COLOR_BGR2RGB);
    ASSERT_EQ(png.size(), cv::Size(64, 48));
    pngs.push_back(png);
  }
  // The camera moves: the lossless frames of the first three angles differ widely (measured 43-55 of 255
  // on the tiny field). Frame 3 repeats frame 0's angle after one of the spiral's two turns; only its
  // depth would differ, and the synthetic cameras do not spread in depth.
  EXPECT_GT(mean_abs_diff(pngs[0], pngs[1]), 20.0);
  EXPECT_GT(mean_abs_diff(pngs[1], pngs[2]), 20.0);
  // The same frames, in order, in both outputs: H.264 at its default rate loses 4-8.5 of 255 on these
  // speckled 64x48 frames (measured), far below the 20+ that tells two angles apart.
  for (size_t k = 0; k < pngs.size(); ++k) EXPECT_LT(mean_abs_diff(pngs[k], v.frames[k]), 12.0) << k;

  r = lrf::test::run_lrf("render '" + field + "' --path orbit --frames 3 --scale 2 --video '" + tmp.str() + "/o.mp4'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Video o = read_video(tmp / "o.mp4");
  ASSERT_EQ(o.frames.size(), 3u);
  EXPECT_EQ(o.frames[0].size(), cv::Size(128, 96));

  // Refusals, each before anything is written: option values and combinations are usage errors (2), what
  // the field or the file named rules out a failure (1).
  const std::vector<std::pair<std::string, int>> refused = {
      {"--path helix", 2}, {"--path spiral --frames 0", 2}, {"--frames 5", 2}, {"--path spiral --split train", 2},
      {"--path spiral --decoder x.safetensors", 1}, {"--path spiral --video '" + tmp.str() + "/x.avi'", 1},
      // A billion frames once made the cameras first, silently, at 300 MB/s.
      {"--path spiral --frames 1000000000", 2}, {"--path spiral --frames 100001", 2}};
  for (const auto& [bad, status] : refused) {
    auto b = lrf::test::run_lrf("render '" + field + "' " + bad);
    EXPECT_EQ(b.exit_code, status) << bad << "\n" << b.output;
  }
  EXPECT_FALSE(fs::exists(tmp / "x.avi"));
}

TEST(Video, RenderPathCliLatent) {
  lrf::test::TempDir tmp("video_cli_latent");
  const std::string field = lrf::test::tiny_field("latent");
  auto r = lrf::test::run_lrf("--threads 2 render '" + field + "' --path interp --frames 4 --video '" + tmp.str() + "/i.mp4'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("decode"), std::string::npos) << r.output;
  const Video v = read_video(tmp / "i.mp4");
  ASSERT_EQ(v.frames.size(), 4u);
  EXPECT_EQ(v.frames[0].size(), cv::Size(64, 48)) << "decoded at 8x the latent size";
  auto b = lrf::test::run_lrf("render '" + field + "' --path interp --scale 2");
  EXPECT_EQ(b.exit_code, 2) << b.output;  // a usage error
}
