#pragma once
// An MP4 video file, written through OpenCV's FFmpeg back end: H.264 ('avc1', what browsers and players
// expect) when the FFmpeg build has an H.264 encoder (Debian's has libx264), else MPEG-4 Part 2 ('mp4v')
// with a warning. Frames go to a temporary file beside the target, renamed into place by finish(), so
// a failed or interrupted run leaves no partial video under the target's name.
#include <memory>
#include <string>

#include <opencv2/core.hpp>

namespace cv {
class VideoWriter;
}

namespace lrf::video {

class Mp4Writer {
 public:
  // Frames are width x height, 8-bit RGB. H.264's 4:2:0 sampling needs even sizes: an odd width or height
  // is padded by repeating the last column or row. Throws lrf::Error naming `path` when it cannot open it.
  Mp4Writer(const std::string& path, int width, int height, double fps);
  ~Mp4Writer();
  Mp4Writer(const Mp4Writer&) = delete;
  Mp4Writer& operator=(const Mp4Writer&) = delete;

  void write(const cv::Mat& rgb8);
  // Closes the file and renames it to the target path.
  void finish();

  // "H.264 (avc1)" or "MPEG-4 Part 2 (mp4v)".
  const std::string& codec() const { return codec_; }
  long frames() const { return frames_; }

 private:
  std::string path_, temp_, codec_;
  int width_, height_;
  long frames_ = 0;
  bool finished_ = false;
  std::unique_ptr<cv::VideoWriter> writer_;
};

}  // namespace lrf::video
