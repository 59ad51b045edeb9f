#pragma once
// The image loss of a latent field seen through a decoder: a rendered normalised latent is mapped back to
// raw latents exactly as for evaluation (clamped to the training range), decoded, and compared with the
// real image by 3DGS's loss (1 - λ)·L1 + λ·(1 - SSIM), taken before the decoder's [0, 1] clamp so that a
// saturated pixel is still pulled back.
//
// Only a window of the image needs decoding: the decoder is split where its whole-image dependencies end
// (Autoencoder::decode_global / decode_local), so a window decoded with `reach` latent cells of context on
// each side gives exactly the pixels that decoding the whole latent would.
#include <cstdint>
#include <random>

#include <torch/types.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/latent/latent_normalization.h"
#include "lrf/scene/camera.h"

namespace lrf {

// In latent cells: the supervised rectangle, and the rectangle decoded for it (clipped to the image).
struct DecodeWindow {
  int64_t y = 0, x = 0, h = 0, w = 0;
  int64_t y0 = 0, x0 = 0, y1 = 0, x1 = 0;  // decoded: rows [y0, y1), columns [x0, x1)
};

// A window of side × side cells at a uniformly random place in an h × w latent (the whole latent when
// side <= 0 or the latent is smaller), decoded with `reach` cells of context where the latent has them;
// reach < 0 (a decoder without a local part) decodes the whole latent.
DecodeWindow plan_window(int64_t h, int64_t w, int64_t side, int reach, std::mt19937_64& rng);

struct DecodedLoss {
  torch::Tensor loss;     // scalar, differentiable in the normalised latent
  torch::Tensor decoded;  // [3, 8·win.h, 8·win.w], unclamped
  torch::Tensor target;   // the matching part of the image
};

// The latent camera whose view shows everything moved by (shift_x, shift_y) image pixels: its principal
// point moved by a shift / 8 of a latent cell.
Camera shifted_latent_camera(const Camera& latent_camera, int shift_x, int shift_y);

// normalised: [C, h, w] rendered normalised latent; image: [3, 8h, 8w] in [0, 1]. A latent rendered by a
// camera shifted by (shift_x, shift_y) / 8 latent cells shows the image moved by (shift_x, shift_y) pixels:
// its pixel (u, v) is compared with the image's (u - shift_x, v - shift_y), where both exist.
DecodedLoss decoded_loss(Autoencoder& ae, const LatentRange& range, const torch::Tensor& normalised,
                         const torch::Tensor& image, const DecodeWindow& window, double lambda_ssim = 0.2,
                         int shift_x = 0, int shift_y = 0);

}  // namespace lrf
