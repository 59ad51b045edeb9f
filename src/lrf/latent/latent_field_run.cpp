#include <filesystem>

#include <torch/torch.h>

#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/cache_key.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/core/run_info.h"
#include "lrf/core/state_dict.h"
#include "lrf/eval/lpips.h"
#include "lrf/eval/metrics.h"
#include "lrf/eval/scores.h"
#include "lrf/latent/latent_cache.h"
#include "lrf/latent/latent_config.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/splat/ply_io.h"

namespace fs = std::filesystem;

namespace lrf {

bool is_latent_run(const std::string& out) {
  const std::string path = (fs::path(out) / "config.json").string();
  if (!fs::exists(path)) return false;
  return splat::config_space(read_json_file(path), path) == "latent";
}

LatentRun open_latent_run(const std::string& out) {
  LatentRun run;
  run.out = out;
  const std::string config_path = (fs::path(out) / "config.json").string();
  if (!fs::exists(config_path)) fail(config_path, "not found: is " + out + " a folder made by 'lrf train'?");
  run.config = read_json_file(config_path);
  const LatentConfig c = parse_latent_config(run.config, config_path);
  run.autoencoder = c.autoencoder;
  run.encoder = c.encoder;
  run.render.sh_degree = c.field.sh_degree;
  run.render.mip = false;
  run.render.background = torch::tensor(c.field.background);
  run.range = c.range;
  // The field only makes sense with the latent space it was fitted in.
  const std::string now = autoencoder_identity(run.autoencoder, run.encoder);
  if (now != c.identity) {
    fail(config_path, "the autoencoder's files changed since training (was " + c.identity + ", now " + now +
                          "): retrain, or restore the weights");
  }
  run.decoder = c.decoder;
  if (!run.decoder.empty() && weights_file_identity(run.decoder) != c.decoder_identity) {
    fail(config_path, "the decoder the field was refined through changed since (" + run.decoder + "): refine again, "
                      "or restore the weights");
  }
  run.scene = load_scene(c.field.scene_root, c.field.scene);
  if (run.scene.views.empty()) fail(config_path, "the scene has no views");
  const auto& res = c.resolution;
  if (res.size() == 2 && (res[0] != run.scene.views[0].camera.width || res[1] != run.scene.views[0].camera.height)) {
    fail(config_path, "the scene's images changed resolution since training");
  }
  const std::string ply = (fs::path(out) / "point_cloud.ply").string();
  if (!fs::exists(ply)) fail(ply, "not found: the run has not finished (resume it with lrf train --resume)");
  if (c.feature_dim > 0) {
    run.field = splat::read_ply(ply, c.feature_dim);
    const std::string lift = (fs::path(out) / "lift.safetensors").string();
    if (!fs::exists(lift)) fail(lift, "not found: a feature field needs the lift it was trained with");
    run.lift = FeatureLift::load(lift, c.feature_dim, run.range.channels());
  } else {
    run.field = splat::read_ply(ply, run.range.channels());
  }
  return run;
}

torch::Tensor render_latent(const LatentRun& run, int view) {
  Camera cam = latent_camera(run.scene.views.at(static_cast<size_t>(view)).camera);
  torch::Tensor rendered = splat::render_field(run.field, cam, run.render).image;
  if (!run.lift.defined()) return rendered;
  torch::NoGradGuard no_grad;
  return run.lift.apply(rendered);
}

nlohmann::json evaluate_latent_run(const std::string& out, const LatentEvalOptions& o) {
  LatentRun run = open_latent_run(out);
  if (run.scene.test_indices.empty()) fail(out, "the scene has no test views");
  const std::string decoder = o.decoder.empty() ? run.decoder : o.decoder;
  auto ae = load_autoencoder(run.autoencoder, run.encoder, decoder);
  std::optional<Lpips> lpips;
  std::string lpips_reason = "no --lpips-weights given (LPIPS needs the VGG16 + lin weights of lpips v0.1)";
  if (!o.lpips_weights.empty()) lpips = Lpips::from_state_dict(tensor_map(load_state_dict(o.lpips_weights)), o.lpips_weights);
  // The encoded test views: the round-trip ceiling and the latent-space reference.
  auto encoded = encode_views_cached(run.scene, run.scene.test_indices, *ae,
                                     autoencoder_identity(run.autoencoder, run.encoder), default_cache_dir());
  const std::string result_dir = o.output_dir.empty() ? out : o.output_dir;
  const std::string image_dir = (fs::path(result_dir) / "eval").string();
  fs::create_directories(result_dir);
  if (o.write_images) fs::create_directories(image_dir);

  torch::NoGradGuard no_grad;
  std::vector<ImageScores> scores;
  nlohmann::json views = nlohmann::json::array();
  double roundtrip_sum = 0, latent_psnr_sum = 0, render_seconds = 0, decode_seconds = 0;
  Progress progress("eval", static_cast<long>(run.scene.test_indices.size()));
  for (size_t k = 0; k < run.scene.test_indices.size(); ++k) {
    const int i = run.scene.test_indices[k];
    const View& v = run.scene.views[static_cast<size_t>(i)];
    auto t0 = std::chrono::steady_clock::now();
    auto zn = render_latent(run, i);
    auto t1 = std::chrono::steady_clock::now();
    auto image = decode_normalised(*ae, run.range, zn);
    auto t2 = std::chrono::steady_clock::now();
    render_seconds += std::chrono::duration<double>(t1 - t0).count();
    decode_seconds += std::chrono::duration<double>(t2 - t1).count();
    cv::Mat truth = run.scene.load_image(i);
    cv::Mat decoded = tensor_to_image(image);
    ImageScores s = score_image(truth, decoded, lpips ? &*lpips : nullptr, v.name);
    scores.push_back(s);
    auto roundtrip = ae->decode(encoded.latents[k].unsqueeze(0)).squeeze(0);
    const double rt = psnr(roundtrip, image_to_chw(truth));
    const double lp = psnr(zn.clamp(0, 1), run.range.normalize(encoded.latents[k]).clamp(0, 1));
    roundtrip_sum += rt;
    latent_psnr_sum += lp;
    auto j = scores_json(s);
    j["name"] = v.name;
    j["roundtrip_psnr"] = rt;
    j["latent_psnr"] = lp;
    views.push_back(j);
    if (o.write_images) write_image_rgb((fs::path(image_dir) / (fs::path(v.name).stem().string() + ".png")).string(), decoded);
    progress.update(static_cast<long>(k + 1), {{"psnr", s.psnr}});
  }
  const double n = double(scores.size());
  ImageScores mean = mean_scores(scores);
  nlohmann::json metrics = scores_json(mean);
  if (!lpips) metrics["lpips_reason"] = lpips_reason;
  metrics["views"] = views;
  metrics["roundtrip_psnr"] = roundtrip_sum / n;
  metrics["latent_psnr"] = latent_psnr_sum / n;
  metrics["resolution"] = {run.scene.views[0].camera.width, run.scene.views[0].camera.height};
  metrics["latent_resolution"] = {run.scene.views[0].camera.width / 8, run.scene.views[0].camera.height / 8};
  metrics["gaussians"] = run.field.size();
  metrics["render_fps"] = n / std::max(render_seconds, 1e-9);
  metrics["decode_fps"] = n / std::max(decode_seconds, 1e-9);
  metrics["decoder"] = decoder.empty() ? "stock" : decoder;
  if (run.config.contains("result") && run.config["result"].is_object()) {
    const auto& result = run.config["result"];
    auto number = [&](const char* key) {
      return result.contains(key) && result[key].is_number() ? result[key].get<double>() : 0.0;
    };
    metrics["train_seconds"] = number("seconds");
    metrics["peak_memory_mb"] = number("peak_memory_mb");
  }
  std::error_code ec;
  const std::string field_file = (fs::path(out) / "point_cloud.ply").string();
  double storage = double(fs::file_size(field_file, ec));
  if (run.lift.defined()) {
    // A feature field is its Gaussians and its lift.
    storage += double(fs::file_size((fs::path(out) / "lift.safetensors").string(), ec));
    metrics["feature_dim"] = run.lift.feature_dim();
  }
  metrics["storage_mb"] = storage / (1 << 20);
  // Which version of the field these scores belong to, so that a reused score can be checked against it.
  metrics["field_stamp"] = file_stamp(field_file);
  metrics["run"] = run_record({{"out", out}, {"decoder", o.decoder}, {"lpips_weights", o.lpips_weights}});
  write_json_file((fs::path(result_dir) / "metrics.json").string(), metrics);
  progress.finish({{"psnr", mean.psnr}, {"ssim", mean.ssim}});
  return metrics;
}

}  // namespace lrf
