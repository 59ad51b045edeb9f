#include "lrf/autoencoder/image_tensor.h"

#include <cmath>

#include <torch/torch.h>

#include "lrf/core/error.h"

namespace lrf {

cv::Mat center_crop_to_multiple(const cv::Mat& image, int multiple) {
  const int w = image.cols / multiple * multiple, h = image.rows / multiple * multiple;
  if (w == 0 || h == 0) {
    fail("image of " + std::to_string(image.cols) + "x" + std::to_string(image.rows) + " is smaller than " +
         std::to_string(multiple) + " pixels");
  }
  return image(cv::Rect((image.cols - w) / 2, (image.rows - h) / 2, w, h)).clone();
}

at::Tensor image_to_batch(const cv::Mat& rgb) {
  if (rgb.type() != CV_32FC3) fail("image_to_batch: expected an RGB float image");
  cv::Mat c = rgb.isContinuous() ? rgb : rgb.clone();
  return torch::from_blob(c.data, {c.rows, c.cols, 3}, torch::kFloat).permute({2, 0, 1}).unsqueeze(0).contiguous();
}

cv::Mat tensor_to_image(const at::Tensor& image) {
  at::Tensor t = image.dim() == 4 ? image[0] : image;
  if (t.dim() != 3 || t.size(0) != 3) fail("tensor_to_image: expected [3,H,W]");
  t = t.detach().to(torch::kCPU, torch::kFloat).permute({1, 2, 0}).contiguous();
  cv::Mat out(static_cast<int>(t.size(0)), static_cast<int>(t.size(1)), CV_32FC3);
  std::memcpy(out.data, t.data_ptr<float>(), static_cast<std::size_t>(t.numel()) * sizeof(float));
  return out;
}

}  // namespace lrf
