#pragma once
// Between OpenCV images (RGB float32 [0,1], HWC) and autoencoder tensors ([B,3,H,W]).
#include <ATen/Tensor.h>
#include <opencv2/core.hpp>

namespace lrf {

// The largest centred crop whose width and height are multiples of `multiple` (the paper's code crops
// this way). Throws lrf::Error if the image is smaller than `multiple` in either direction.
cv::Mat center_crop_to_multiple(const cv::Mat& image, int multiple);
// CV_32FC3 -> [1,3,H,W] float32 (a copy).
at::Tensor image_to_batch(const cv::Mat& rgb);
// [3,H,W] or [1,3,H,W] -> CV_32FC3 (a copy).
cv::Mat tensor_to_image(const at::Tensor& image);

}  // namespace lrf
