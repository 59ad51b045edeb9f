#pragma once
// Scoring a field with the detail pass: what `lrf eval --detail` and the latent-refined+detail row of
// lrf compare write alike.
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/detail/detail_blend.h"
#include "lrf/field_kinds/field_type.h"

namespace lrf::detail {

// The field's scoring (a decoder override for a latent field, LPIPS weights; frames are scored at the
// field's resolution, so a scale other than 1 is refused) with the detail pass's options.
struct DetailEvalOptions : FieldScoring {
  DetailOptions detail;
};

// The options as recorded in metrics.json ("detail") and compared to tell whether a score is reusable.
nlohmann::json detail_options_json(const DetailOptions& options);

// Scores RUN's test views with the detail pass, writes the frames to RESULT_DIR/eval/*.png and the scores
// to RESULT_DIR/metrics.json, and returns them: the means, each view's scores, the time per frame in its
// parts (render_fps, decode_fps, detail_ms), "depth_maps_seconds" (the field's depth from each borrowed
// training camera, made once per scene), the training views borrowed ("borrowed_views"), the options, and
// the photographs' storage ("photographs_mb"). `base_metrics` (RUN's own metrics.json, may be null) gives
// the field's cost (train_seconds, peak_memory_mb, gaussians, storage_mb, to which the photographs are
// added) and what the pass leaves as it was (roundtrip_psnr, latent_psnr). Throws lrf::Error naming the folder for a latent NeRF or a run without training views.
nlohmann::json evaluate_with_detail(const std::string& run, const std::string& result_dir,
                                    const DetailEvalOptions& options, const nlohmann::json* base_metrics = nullptr);

}  // namespace lrf::detail
