#pragma once
// Rendering a camera path into an MP4 video and/or numbered PNG frames, with a progress bar.
#include <string>
#include <vector>

#include "lrf/frames/field_frames.h"
#include "lrf/scene/camera.h"

namespace lrf::video {

struct PathVideoOptions {
  std::string video;       // .mp4 file ("" = none)
  std::string frames_dir;  // folder for frame_0000.png ... ("" = none)
  double fps = 30;
};

struct PathVideoResult {
  long frames = 0;
  double seconds = 0;         // wall time of the whole job
  double render_seconds = 0;  // splatting
  double decode_seconds = 0;  // latent fields' decoder
  std::string codec;          // of the video ("" without one)
};

// Renders every camera of `path` (all of one size) through `frames`. Throws lrf::Error before rendering
// anything when the options are unusable.
PathVideoResult render_path_video(FieldFrames& frames, const std::vector<Camera>& path, const PathVideoOptions& options);

}  // namespace lrf::video
