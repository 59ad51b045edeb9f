#pragma once
// Scoring whatever frames a FieldFrames makes (with or without a detail pass) on its scene's test views,
// frame by frame as a viewer would show them (8-bit).
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/eval/lpips.h"
#include "lrf/frames/field_frames.h"

namespace lrf {

// Renders every test view of frames.scene() at its camera, scores it against the photograph (PSNR, SSIM,
// MS-SSIM, FLIP, LPIPS when `lpips` is given) and, when `image_dir` is not empty, writes it there as
// <name>.png. Returns the means, "views" (each view's scores) and the time per frame in its parts
// ("render_ms", "decode_ms", "detail_ms", "frame_fps"). Throws lrf::Error when the scene has no test views.
nlohmann::json score_frames_on_test_views(FieldFrames& frames, const std::string& image_dir,
                                          const Lpips* lpips = nullptr);

}  // namespace lrf
