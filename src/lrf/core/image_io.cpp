#include "lrf/core/image_io.h"

#include <algorithm>
#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

// A JPEG cut short (an interrupted copy or download) still decodes: libjpeg fills the missing rows with grey
// and only prints "Premature end of JPEG file", naming no file. Its end-of-image marker (FF D9) is then
// missing from the file's tail, which is checked here (in the last 4 KB, since some cameras append a few
// bytes after it).
void refuse_truncated_jpeg(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char head[2] = {0, 0};
  if (!in.read(reinterpret_cast<char*>(head), 2) || head[0] != 0xFF || head[1] != 0xD8) return;  // not a JPEG
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff tail = std::min<std::streamoff>(size, 4096);
  std::string bytes(static_cast<size_t>(tail), '\0');
  in.seekg(size - tail);
  if (!in.read(bytes.data(), tail)) return;
  if (bytes.find("\xFF\xD9") == std::string::npos) {
    fail(path, "truncated JPEG: the file ends without its end-of-image marker (an interrupted copy or download?)");
  }
}

}  // namespace

cv::Mat read_image_rgb(const std::string& path, ExifOrientation orientation) {
  if (!std::filesystem::exists(path)) fail(path, "image file not found");
  refuse_truncated_jpeg(path);
  const int flags = orientation == ExifOrientation::as_stored ? cv::IMREAD_COLOR | cv::IMREAD_IGNORE_ORIENTATION
                                                              : cv::IMREAD_COLOR;
  cv::Mat bgr = cv::imread(path, flags);
  if (bgr.empty()) fail(path, "cannot decode image (corrupt or unsupported format)");
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return to_float(rgb);
}

cv::Size read_image_size(const std::string& path) {
  // OpenCV has no header-only probe; decoding at reduced size keeps this cheap for large JPEGs is not
  // exact, so decode once fully. Callers do this for one image per scene.
  if (!std::filesystem::exists(path)) fail(path, "image file not found");
  cv::Mat img = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (img.empty()) fail(path, "cannot decode image (corrupt or unsupported format)");
  return img.size();
}

cv::Mat to_u8(const cv::Mat& rgb_float) {
  if (rgb_float.depth() == CV_8U) return rgb_float;
  cv::Mat out;
  rgb_float.convertTo(out, CV_8U, 255.0);  // saturate_cast rounds and clamps
  return out;
}

cv::Mat to_float(const cv::Mat& rgb_u8) {
  if (rgb_u8.depth() == CV_32F) return rgb_u8;
  cv::Mat out;
  rgb_u8.convertTo(out, CV_32F, 1.0 / 255.0);
  return out;
}

void write_image_rgb(const std::string& path, const cv::Mat& rgb) {
  cv::Mat u8 = to_u8(rgb);
  cv::Mat bgr;
  if (u8.channels() == 3) {
    cv::cvtColor(u8, bgr, cv::COLOR_RGB2BGR);
  } else {
    bgr = u8;
  }
  std::string ext = std::filesystem::path(path).extension().string();
  if (ext.empty()) ext = ".png";
  std::vector<uchar> bytes;
  if (!cv::imencode(ext, bgr, bytes)) fail(path, "cannot encode image as " + ext);
  write_file_atomic(path, std::string(bytes.begin(), bytes.end()));
}

cv::Mat resize_area(const cv::Mat& image, int width, int height) {
  if (image.cols == width && image.rows == height) return image;
  cv::Mat out;
  int interp = (width < image.cols || height < image.rows) ? cv::INTER_AREA : cv::INTER_CUBIC;
  cv::resize(image, out, cv::Size(width, height), 0, 0, interp);
  return out;
}

}  // namespace lrf
