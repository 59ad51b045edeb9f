#include "lrf/finetune/consistency.h"

#include <torch/torch.h>

#include "lrf/align/correspondence_loss.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/eval/metrics.h"

namespace lrf {

nlohmann::json ConsistencyReport::to_json() const {
  return {{"views", views},
          {"pairs", pairs},
          {"matches", matches},
          {"width", width},
          {"height", height},
          {"correspondence_l1", correspondence_l1},
          {"latent_mean_abs_deviation", latent_mean_abs_deviation},
          {"correspondence_relative", correspondence_relative},
          {"roundtrip_psnr", roundtrip_psnr},
          {"high_frequency_share", high_frequency_share}};
}

ConsistencyReport measure_consistency(const PairScene& ps, Autoencoder& ae) {
  torch::NoGradGuard no_grad;
  ConsistencyReport r;
  const Scene& scene = ps.scene;
  r.views = scene.views.size();
  r.width = scene.views[0].camera.width;
  r.height = scene.views[0].camera.height;
  std::vector<at::Tensor> latents;
  double psnr_sum = 0, hf_sum = 0, mad_sum = 0;
  for (size_t i = 0; i < scene.views.size(); ++i) {
    at::Tensor x = image_to_batch(scene.load_image(static_cast<int>(i)));
    at::Tensor z = ae.encode(x);
    psnr_sum += psnr(ae.decode(z)[0], x[0]);
    at::Tensor zi = z[0];
    hf_sum += high_frequency_energy_share(zi);
    mad_sum += (zi - zi.mean({1, 2}, true)).abs().mean().item<double>();
    latents.push_back(zi);
  }
  r.roundtrip_psnr = psnr_sum / r.views;
  r.high_frequency_share = hf_sum / r.views;
  r.latent_mean_abs_deviation = mad_sum / r.views;
  // Every match counts once: the pair means are weighted by their match counts.
  double l1_sum = 0;
  for (const auto& p : ps.correspondences.pairs) {
    if (p.xi.empty()) continue;
    auto to_tensor = [](const std::vector<Eigen::Vector2f>& v) {
      return torch::from_blob(const_cast<Eigen::Vector2f*>(v.data()), {static_cast<int64_t>(v.size()), 2},
                              torch::kFloat)
          .clone();
    };
    at::Tensor l1 = correspondence_l1(latents[p.view_i], latents[p.view_j], to_tensor(p.xi), to_tensor(p.xj), ae.factor());
    l1_sum += l1.item<double>() * static_cast<double>(p.xi.size());
    r.matches += p.xi.size();
    ++r.pairs;
  }
  r.correspondence_l1 = r.matches ? l1_sum / static_cast<double>(r.matches) : 0.0;
  r.correspondence_relative = r.latent_mean_abs_deviation > 0 ? r.correspondence_l1 / r.latent_mean_abs_deviation : 0.0;
  return r;
}

}  // namespace lrf
