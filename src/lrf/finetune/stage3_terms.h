#pragma once
// The loss terms of one Stage III step (training views' rendered latents, held-out views' rendered latents,
// and encoded training images for the round trip), decoded together.
#include <string>
#include <utility>
#include <vector>

#include <ATen/Tensor.h>

#include "lrf/finetune/finetune_loop.h"

namespace lrf {

class Autoencoder;

// One term: its crops (raw latents [B, C, h, w] and images [B, 3, 8h, 8w]), its weight in the step's loss and
// the name its value is reported under.
struct Stage3Term {
  std::string metric;
  double weight = 0;
  std::pair<at::Tensor, at::Tensor> crops;
};

// Each term's loss (mean L1, or its mix with D-SSIM when lambda_ssim > 0) over the crops this rank takes,
// scaled to this rank's part of it, from one decoder pass over every term's crops stacked into one batch: at
// Stage III's small crops a decoder pass is dominated by its layers' fixed costs, so one pass of 3 x 2
// crops trains faster than three passes of 2 (docs/speed.md). The terms' crops must share a size.
std::vector<at::Tensor> stage3_term_losses(Autoencoder& ae, const std::vector<Stage3Term>& terms,
                                           const BatchShare& share, double lambda_ssim);

}  // namespace lrf
