#include "lrf/latent/latent_scoring.h"

#include <chrono>
#include <filesystem>
#include <optional>

#include <torch/torch.h>

#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/cache_key.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/progress.h"
#include "lrf/core/run_info.h"
#include "lrf/core/state_dict.h"
#include "lrf/eval/metrics.h"
#include "lrf/eval/scores.h"
#include "lrf/latent/latent_cache.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"

namespace fs = std::filesystem;

namespace lrf {

nlohmann::json score_latent_test_views(const LatentScoring& in) {
  const Scene& scene = *in.scene;
  if (scene.test_indices.empty()) fail(scene.root, "the scene has no test views");
  auto encoded = encode_views_cached(scene, scene.test_indices, *in.autoencoder, in.autoencoder_identity,
                                     default_cache_dir());
  if (!in.image_dir.empty()) fs::create_directories(in.image_dir);
  torch::NoGradGuard no_grad;
  std::vector<ImageScores> scores;
  nlohmann::json views = nlohmann::json::array();
  double roundtrip_sum = 0, latent_psnr_sum = 0, render_seconds = 0, decode_seconds = 0;
  Progress progress("eval", static_cast<long>(scene.test_indices.size()));
  for (size_t k = 0; k < scene.test_indices.size(); ++k) {
    const int i = scene.test_indices[k];
    const View& v = scene.views[static_cast<size_t>(i)];
    auto t0 = std::chrono::steady_clock::now();
    auto zn = in.render(i);
    auto t1 = std::chrono::steady_clock::now();
    auto image = decode_normalised(*in.autoencoder, *in.range, zn);
    auto t2 = std::chrono::steady_clock::now();
    render_seconds += std::chrono::duration<double>(t1 - t0).count();
    decode_seconds += std::chrono::duration<double>(t2 - t1).count();
    cv::Mat truth = scene.load_image(i);
    cv::Mat decoded = tensor_to_image(image);
    ImageScores s = score_image(truth, decoded, in.lpips, v.name);
    scores.push_back(s);
    auto roundtrip = in.autoencoder->decode(encoded.latents[k].unsqueeze(0)).squeeze(0);
    const double rt = psnr(roundtrip, image_to_chw(truth));
    const double lp = psnr(zn.clamp(0, 1), in.range->normalize(encoded.latents[k]).clamp(0, 1));
    roundtrip_sum += rt;
    latent_psnr_sum += lp;
    auto j = scores_json(s);
    j["name"] = v.name;
    j["roundtrip_psnr"] = rt;
    j["latent_psnr"] = lp;
    views.push_back(j);
    if (!in.image_dir.empty())
      write_image_rgb((fs::path(in.image_dir) / (fs::path(v.name).stem().string() + ".png")).string(), decoded);
    progress.update(static_cast<long>(k + 1), {{"psnr", s.psnr}});
  }
  const double n = double(scores.size());
  const ImageScores mean = mean_scores(scores);
  nlohmann::json metrics = scores_json(mean);
  metrics["views"] = views;
  metrics["roundtrip_psnr"] = roundtrip_sum / n;
  metrics["latent_psnr"] = latent_psnr_sum / n;
  const Camera& c0 = scene.views[0].camera;
  metrics["resolution"] = {c0.width, c0.height};
  metrics["latent_resolution"] = {c0.width / 8, c0.height / 8};
  metrics["render_fps"] = n / std::max(render_seconds, 1e-9);
  metrics["decode_fps"] = n / std::max(decode_seconds, 1e-9);
  progress.finish({{"psnr", mean.psnr}, {"ssim", mean.ssim}});
  return metrics;
}

namespace {

// Where a run's scores (and its eval/ images) go: the run folder unless --output names another.
std::string result_dir_of(const std::string& out, const LatentEvalOptions& o) {
  return o.output_dir.empty() ? out : o.output_dir;
}

}  // namespace

nlohmann::json score_latent_run(const std::string& out, const Scene& scene, const LatentRange& range,
                                const std::string& autoencoder, const std::string& encoder,
                                const std::string& decoder, const LatentEvalOptions& o,
                                const std::function<torch::Tensor(int view)>& render) {
  auto ae = load_autoencoder(autoencoder, encoder, decoder);
  std::optional<Lpips> lpips;
  if (!o.lpips_weights.empty())
    lpips = Lpips::from_state_dict(tensor_map(load_state_dict(o.lpips_weights)), o.lpips_weights);
  const std::string result_dir = result_dir_of(out, o);
  fs::create_directories(result_dir);
  LatentScoring scoring;
  scoring.scene = &scene;
  scoring.range = &range;
  scoring.autoencoder = ae.get();
  scoring.autoencoder_identity = autoencoder_identity(autoencoder, encoder);
  scoring.lpips = lpips ? &*lpips : nullptr;
  scoring.image_dir = o.write_images ? (fs::path(result_dir) / "eval").string() : "";
  scoring.render = render;
  nlohmann::json metrics = score_latent_test_views(scoring);
  if (!lpips) metrics["lpips_reason"] = "no --lpips-weights given (LPIPS needs the VGG16 + lin weights of lpips v0.1)";
  metrics["decoder"] = decoder.empty() ? "stock" : decoder;
  return metrics;
}

void write_latent_run_metrics(const std::string& out, const LatentEvalOptions& o, const nlohmann::json& config,
                              const std::string& field_file, nlohmann::json& metrics) {
  if (config.contains("result") && config["result"].is_object()) {
    const auto& result = config["result"];
    auto number = [&](const char* key) {
      return result.contains(key) && result[key].is_number() ? result[key].get<double>() : 0.0;
    };
    // The wall time of everything the row needs: encoding the training views, the fit, and (a refined
    // field) its refinement; each part beside it.
    metrics["encode_seconds"] = number("encode_seconds");
    metrics["fit_seconds"] = result.contains("stage2_seconds") ? number("stage2_seconds") : number("seconds");
    if (result.contains("refine_seconds")) metrics["refine_seconds"] = number("refine_seconds");
    metrics["train_seconds"] = number("seconds") + number("encode_seconds");
    metrics["peak_memory_mb"] = number("peak_memory_mb");
  }
  metrics["field_stamp"] = file_stamp(field_file);
  metrics["run"] = run_record({{"out", out}, {"decoder", o.decoder}, {"lpips_weights", o.lpips_weights}});
  write_json_file((fs::path(result_dir_of(out, o)) / "metrics.json").string(), metrics);
}

}  // namespace lrf
