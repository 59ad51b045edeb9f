#pragma once
// Image files in and out. Images inside lrf are RGB (not OpenCV's BGR), float32 in [0, 1] (CV_32FC3)
// unless a function says otherwise.
#include <string>

#include <opencv2/core.hpp>

namespace lrf {

// What a JPEG's EXIF orientation tag does to its pixels. A scene's images are read as stored, because
// that is how COLMAP posed them (a phone photo tagged "rotate 90" used to be turned upright here and then
// refused as "images of mixed sizes"); a photo on its own is turned upright, as an image viewer shows it.
enum class ExifOrientation { upright, as_stored };

// Decodes an image file as RGB float32 in [0, 1]; throws lrf::Error if missing or unreadable.
cv::Mat read_image_rgb(const std::string& path, ExifOrientation orientation = ExifOrientation::upright);
// Width and height of an image file as stored (no EXIF rotation) without keeping its pixels.
cv::Size read_image_size(const std::string& path);
// Writes an RGB float image (values clamped to [0, 1]) or an 8-bit RGB image as PNG/JPG, atomically.
void write_image_rgb(const std::string& path, const cv::Mat& rgb);
// Area-filtered resize (the right filter for downscaling photographs).
cv::Mat resize_area(const cv::Mat& image, int width, int height);
// Float RGB [0,1] <-> 8-bit RGB with rounding.
cv::Mat to_u8(const cv::Mat& rgb_float);
cv::Mat to_float(const cv::Mat& rgb_u8);

}  // namespace lrf
