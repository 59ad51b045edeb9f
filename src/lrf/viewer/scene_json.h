#pragma once
// What the viewer's page learns about the field (GET /api/scene) and the bounds the server holds its
// frame requests to, both from the field's scene.
#include <nlohmann/json.hpp>

#include "lrf/frames/field_frames.h"
#include "lrf/viewer/frame_request.h"

namespace lrf::viewer {

// The scene's centre is the cameras' mean; its radius the larger of the cameras' spread and the 99%
// quantile of the SfM points' distances from that centre.
ViewLimits view_limits(const FieldFrames& frames, int max_side);

// {space (rgb, latent or latent-nerf), description, size_multiple, max_side, center, radius, target, up,
// views: [{name, split, width, height, fx, fy, cx, cy, R (row-major), t}]}.
nlohmann::json scene_json(const FieldFrames& frames, const ViewLimits& limits);

}  // namespace lrf::viewer
