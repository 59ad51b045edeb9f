#include "lrf/detail/detail_eval.h"

#include <cmath>
#include <filesystem>
#include <optional>

#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/run_info.h"
#include "lrf/core/state_dict.h"
#include "lrf/detail/detail_frames.h"
#include "lrf/eval/lpips.h"
#include "lrf/field_kinds/field_type.h"
#include "lrf/frames/test_view_scores.h"

namespace fs = std::filesystem;

namespace lrf::detail {

nlohmann::json detail_options_json(const DetailOptions& d) {
  return {{"views", d.views},
          {"blur_sigma", d.blur_sigma},
          {"agreement", d.agreement},
          {"consistency", d.consistency},
          {"decoded_weight", d.decoded_weight},
          {"calibration_views", d.calibration_views},
          {"learned_blend", d.learned_blend},
          {"learning_views", d.learning_views},
          {"learning_steps", d.learning_steps},
          {"occlusion_tolerance", d.occlusion_tolerance},
          {"high_frequencies_only", d.high_frequencies_only},
          {"sweep_range", d.sweep_range},
          {"sweep_steps", d.sweep_steps},
          {"sweep_window", d.sweep_window}};
}

nlohmann::json evaluate_with_detail(const std::string& run, const std::string& result_dir,
                                    const DetailEvalOptions& options, const nlohmann::json* base_metrics) {
  if (options.scale != 1.0) fail_usage("--scale does not apply with --detail: frames are scored at the field's resolution");
  DetailFrames frames(open_field_frames(run, options.decoder), options.detail);
  log_info(frames.describe());
  std::optional<Lpips> lpips;
  if (!options.lpips_weights.empty())
    lpips = Lpips::from_state_dict(tensor_map(load_state_dict(options.lpips_weights)), options.lpips_weights);
  fs::create_directories(result_dir);
  nlohmann::json m =
      score_frames_on_test_views(frames, (fs::path(result_dir) / "eval").string(), lpips ? &*lpips : nullptr);
  if (!lpips) m["lpips_reason"] = "no --lpips-weights given (LPIPS needs the VGG16 + lin weights of lpips v0.1)";
  const double ms_to_fps = 1000.0;
  if (m["render_ms"].get<double>() > 0) m["render_fps"] = ms_to_fps / m["render_ms"].get<double>();
  if (m["decode_ms"].get<double>() > 0) m["decode_fps"] = ms_to_fps / m["decode_ms"].get<double>();
  m["depth_maps_seconds"] = frames.source_seconds();
  // The pass needs the training photographs beside the field: they count in its storage.
  double photographs_bytes = 0;
  m["borrowed_views"] = nlohmann::json::array();
  for (int v : frames.borrowed_views()) m["borrowed_views"].push_back(frames.scene().views[v].name);
  for (int v : frames.scene().train_indices) {
    std::error_code ec;
    const auto bytes = fs::file_size(frames.scene().views[v].image_path, ec);
    if (!ec) photographs_bytes += static_cast<double>(bytes);
  }
  m["photographs_mb"] = photographs_bytes / (1 << 20);
  if (base_metrics) {
    for (const char* key : {"train_seconds", "encode_seconds", "fit_seconds", "refine_seconds", "peak_memory_mb",
                            "gaussians", "roundtrip_psnr", "latent_psnr"}) {
      if (base_metrics->contains(key)) m[key] = (*base_metrics)[key];
    }
    if (base_metrics->contains("storage_mb") && (*base_metrics)["storage_mb"].is_number())
      m["storage_mb"] = (*base_metrics)["storage_mb"].get<double>() + m["photographs_mb"].get<double>();
  }
  m["detail"] = detail_options_json(options.detail);
  m["detail"]["decoded_weight"] = std::isfinite(frames.decoded_weight()) ? nlohmann::json(frames.decoded_weight())
                                                                         : nlohmann::json("decoded only");
  // Chosen on training views only: every test-view score above is of frames made after it.
  if (!frames.calibration().scores.empty()) {
    nlohmann::json scores = nlohmann::json::array();
    for (const auto& c : frames.calibration().scores) {
      scores.push_back({{"decoded_weight", std::isfinite(c.decoded_weight) ? nlohmann::json(c.decoded_weight)
                                                                           : nlohmann::json("decoded only")},
                        {"psnr", c.psnr}});
    }
    nlohmann::json views = nlohmann::json::array();
    for (int v : frames.calibration_views()) views.push_back(frames.scene().views[v].name);
    m["calibration"] = {{"training_views", views}, {"scores", scores}, {"seconds", frames.calibration_seconds()}};
  }
  if (options.detail.learned_blend) {
    const auto& r = frames.network_report();
    m["learned_blend"] = {{"learned_on_views", r.learned_on}, {"held_out_views", r.held_out},
                          {"held_out_psnr_learned", r.learned_psnr}, {"held_out_psnr_handmade", r.handmade_psnr},
                          {"seconds", r.seconds}, {"used", r.used}};
  }
  m["decoder"] = options.decoder.empty() ? "the run's own" : options.decoder;
  m["run"] = run_record({{"field", run}, {"decoder", options.decoder}, {"lpips_weights", options.lpips_weights}});
  write_json_file((fs::path(result_dir) / "metrics.json").string(), m);
  return m;
}

}  // namespace lrf::detail
