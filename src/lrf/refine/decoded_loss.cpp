#include "lrf/refine/decoded_loss.h"

#include <algorithm>

#include <ATen/ATen.h>

#include "lrf/core/error.h"
#include "lrf/splat/train/loss.h"

namespace lrf {

DecodeWindow plan_window(int64_t h, int64_t w, int64_t side, int reach, std::mt19937_64& rng) {
  if (h < 1 || w < 1) fail("plan_window: empty latent");
  DecodeWindow win;
  win.h = side > 0 ? std::min(side, h) : h;
  win.w = side > 0 ? std::min(side, w) : w;
  win.y = std::uniform_int_distribution<int64_t>(0, h - win.h)(rng);
  win.x = std::uniform_int_distribution<int64_t>(0, w - win.w)(rng);
  if (reach < 0) {
    win.y0 = 0, win.x0 = 0, win.y1 = h, win.x1 = w;
  } else {
    win.y0 = std::max<int64_t>(0, win.y - reach);
    win.x0 = std::max<int64_t>(0, win.x - reach);
    win.y1 = std::min(h, win.y + win.h + reach);
    win.x1 = std::min(w, win.x + win.w + reach);
  }
  return win;
}

Camera shifted_latent_camera(const Camera& latent_camera, int shift_x, int shift_y) {
  Camera shifted = latent_camera;
  shifted.cx += shift_x / 8.0;
  shifted.cy += shift_y / 8.0;
  return shifted;
}

DecodedLoss decoded_loss(Autoencoder& ae, const LatentRange& range, const at::Tensor& normalised,
                         const at::Tensor& image, const DecodeWindow& win, double lambda_ssim, int shift_x,
                         int shift_y) {
  if (normalised.dim() != 3 || image.dim() != 3 || image.size(0) != 3 || image.size(1) != 8 * normalised.size(1) ||
      image.size(2) != 8 * normalised.size(2)) {
    fail("decoded_loss: latent " + std::string(c10::str(normalised.sizes())) + " and image " +
         std::string(c10::str(image.sizes())) + " do not match (the image must be 8x the latent)");
  }
  if (win.y < win.y0 || win.x < win.x0 || win.y + win.h > win.y1 || win.x + win.w > win.x1 || win.y0 < 0 ||
      win.x0 < 0 || win.y1 > normalised.size(1) || win.x1 > normalised.size(2) || win.h < 1 || win.w < 1) {
    fail("decoded_loss: the window does not lie inside the latent");
  }
  if (shift_x < 0 || shift_y < 0 || shift_x >= 8 * win.w || shift_y >= 8 * win.h)
    fail("decoded_loss: the shift must be at least 0 and smaller than the window");
  const at::Tensor features = ae.decode_global(range.denormalize(normalised).unsqueeze(0));
  const CellRect inner{win.y - win.y0, win.x - win.x0, win.h, win.w};
  const WindowEdges edges{win.y0 == 0, win.x0 == 0, win.y1 == normalised.size(1), win.x1 == normalised.size(2)};
  const at::Tensor supervised = ae.decode_local_window(
      features.narrow(2, win.y0, win.y1 - win.y0).narrow(3, win.x0, win.x1 - win.x0), inner, edges)[0];
  // The window's pixels, in the shifted view, start at (8 win.y, 8 win.x); in the image at that minus the
  // shift, so a window at the top or left edge loses the rows and columns the image has no pixels for.
  const int64_t top = std::max<int64_t>(0, shift_y - 8 * win.y), left = std::max<int64_t>(0, shift_x - 8 * win.x);
  DecodedLoss out;
  out.decoded = supervised.narrow(1, top, 8 * win.h - top).narrow(2, left, 8 * win.w - left).contiguous();
  out.target = image.narrow(1, 8 * win.y - shift_y + top, 8 * win.h - top)
                   .narrow(2, 8 * win.x - shift_x + left, 8 * win.w - left)
                   .contiguous();
  out.loss = splat::photometric_loss(out.decoded, out.target, lambda_ssim);
  return out;
}

}  // namespace lrf
