#include "lrf/finetune/stage3_terms.h"

#include <torch/torch.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/splat/train/loss.h"

namespace lrf {

std::vector<at::Tensor> stage3_term_losses(Autoencoder& ae, const std::vector<Stage3Term>& terms,
                                           const BatchShare& share, double lambda_ssim) {
  auto mine = [&](const at::Tensor& t) {
    return share.count == share.total ? t : t.narrow(0, share.first, share.count);
  };
  std::vector<at::Tensor> latents, images;
  for (const Stage3Term& t : terms) {
    latents.push_back(mine(t.crops.first));
    images.push_back(mine(t.crops.second));
  }
  if (latents.empty()) return {};
  const at::Tensor decoded = ae.decode_unclamped(latents.size() == 1 ? latents[0] : at::cat(latents));
  const double part = share_weight(share);
  std::vector<at::Tensor> losses;
  int64_t first = 0;
  for (const at::Tensor& image : images) {
    const at::Tensor own = decoded.narrow(0, first, image.size(0));
    first += image.size(0);
    at::Tensor l = lambda_ssim == 0 ? (own - image).abs().mean() : splat::photometric_loss(own, image, lambda_ssim);
    losses.push_back(part == 1.0 ? l : l * part);
  }
  return losses;
}

}  // namespace lrf
