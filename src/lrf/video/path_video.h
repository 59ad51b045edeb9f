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
  bool stability = false;  // also measure frame-to-frame stability (detail/frame_stability.h; splat fields)
};

struct PathVideoResult {
  long frames = 0;
  double seconds = 0;         // wall time of the whole job
  double render_seconds = 0;  // splatting
  double decode_seconds = 0;  // latent fields' decoder
  std::string codec;          // of the video ("" without one)
  double detail_seconds = 0;  // the detail pass, when the frames have one
  double warp_error = -1;     // with options.stability: mean 8-bit difference of consecutive frames after the
                              //   warp (lower is steadier); -1 otherwise
};

// Renders every camera of `path` (all of one size) through `frames`. Throws lrf::Error before rendering
// anything when the options are unusable.
PathVideoResult render_path_video(FieldFrames& frames, const std::vector<Camera>& path, const PathVideoOptions& options);

}  // namespace lrf::video
