#include "lrf/video/mp4_writer.h"

#include <unistd.h>

#include <filesystem>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"

namespace fs = std::filesystem;

namespace lrf::video {
namespace {

// FFmpeg picks the container from the extension, so the temporary name keeps ".mp4" at its end.
std::string temp_name(const std::string& path) {
  const fs::path p(path);
  return (p.parent_path() / ("." + p.stem().string() + ".partial" + std::to_string(::getpid()) + ".mp4")).string();
}

}  // namespace

Mp4Writer::Mp4Writer(const std::string& path, int width, int height, double fps)
    : path_(path), temp_(temp_name(path)), width_(width), height_(height) {
  if (width < 2 || height < 2 || width > 8192 || height > 8192)
    fail(path, "video frames must be 2..8192 pixels wide and high (got " + std::to_string(width) + "x" +
                   std::to_string(height) + ")");
  if (!(fps > 0 && fps <= 240)) fail(path, "the frame rate must be in (0, 240] (got " + std::to_string(fps) + ")");
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty() && !fs::is_directory(parent)) fail(path, "output folder does not exist");
  const cv::Size size(width + width % 2, height + height % 2);
  writer_ = std::make_unique<cv::VideoWriter>();
  if (writer_->open(temp_, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('a', 'v', 'c', '1'), fps, size)) {
    codec_ = "H.264 (avc1)";
  } else if (writer_->open(temp_, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps, size)) {
    codec_ = "MPEG-4 Part 2 (mp4v)";
    log_warn("this OpenCV/FFmpeg build has no H.264 encoder: " + path + " is MPEG-4 Part 2 ('mp4v'), which "
             "browsers may not play; install FFmpeg with libx264 (Debian's libavcodec has it) for H.264");
  } else {
    std::remove(temp_.c_str());
    fail(path, "cannot open an MP4 writer: OpenCV was built without FFmpeg video output, or the folder is not writable");
  }
}

Mp4Writer::~Mp4Writer() {
  if (!finished_) {
    writer_.reset();
    std::remove(temp_.c_str());
  }
}

void Mp4Writer::write(const cv::Mat& rgb8) {
  if (finished_) fail(path_, "write after finish");
  if (rgb8.type() != CV_8UC3 || rgb8.cols != width_ || rgb8.rows != height_)
    fail(path_, "a frame of " + std::to_string(rgb8.cols) + "x" + std::to_string(rgb8.rows) +
                    " does not match the video's " + std::to_string(width_) + "x" + std::to_string(height_));
  cv::Mat bgr;
  cv::cvtColor(rgb8, bgr, cv::COLOR_RGB2BGR);
  if (width_ % 2 || height_ % 2) cv::copyMakeBorder(bgr, bgr, 0, height_ % 2, 0, width_ % 2, cv::BORDER_REPLICATE);
  writer_->write(bgr);
  ++frames_;
}

void Mp4Writer::finish() {
  if (finished_) return;
  writer_->release();
  std::error_code ec;
  if (frames_ == 0 || !fs::exists(temp_, ec) || fs::file_size(temp_, ec) == 0) {
    std::remove(temp_.c_str());
    fail(path_, frames_ == 0 ? "no frames were written" : "the encoder wrote nothing");
  }
  finished_ = true;  // move_into_place removes the temporary file itself when it fails
  move_into_place(temp_, path_);
}

}  // namespace lrf::video
