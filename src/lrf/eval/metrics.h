#pragma once
// Image-quality metrics as the 3D Gaussian Splatting evaluation computes them (its metrics.py), so that our
// numbers can be set beside the paper's: PSNR over all channels and pixels, and SSIM with an 11x11 Gaussian
// window (sigma 1.5), C1 = 0.01^2, C2 = 0.03^2, same-size zero padding, averaged over channels and pixels.
//
// Images are [C, H, W] float tensors (or RGB cv::Mat, float in [0, 1] or 8-bit). Both images are clamped to
// [0, max] first, as 3DGS clamps its renders before scoring. Sums are taken in float64.
#include <opencv2/core.hpp>
#include <torch/torch.h>

namespace lrf {

// PSNR of identical images is infinite; JSON cannot hold that, so every PSNR is capped at this value
// (an MSE below 1e-10 of the peak squared). Real renders score far below it.
constexpr double kPsnrCapDb = 100.0;

// 10·log10(peak² / mse_value), capped at kPsnrCapDb (an MSE of 0 scores the cap).
double psnr_from_mse(double mse_value, double peak = 1.0);

// Mean squared error over all elements, in float64, no clamping (for latents and other unbounded data).
double mse(const torch::Tensor& a, const torch::Tensor& b);
// 10·log10(peak² / MSE) with no clamping of the inputs, capped at kPsnrCapDb (for latent-space PSNR).
double psnr_unclamped(const torch::Tensor& a, const torch::Tensor& b, double peak);

// Image PSNR in dB: inputs clamped to [0, max], capped at kPsnrCapDb.
double psnr(const torch::Tensor& a, const torch::Tensor& b, double max = 1.0);
double psnr(const cv::Mat& a, const cv::Mat& b);

// Image SSIM (mean of the SSIM map over channels and pixels), inputs clamped to [0, max]. The constants are
// (0.01·max)² and (0.03·max)², which for max = 1 are 3DGS's.
double ssim(const torch::Tensor& a, const torch::Tensor& b, double max = 1.0);
double ssim(const cv::Mat& a, const cv::Mat& b);

// [C, H, W] float32 tensor of an RGB cv::Mat (float in [0, 1] or 8-bit, 1 or 3 channels); copies.
torch::Tensor image_to_chw(const cv::Mat& image);

}  // namespace lrf
