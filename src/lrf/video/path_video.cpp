#include "lrf/video/path_video.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/progress.h"
#include "lrf/detail/frame_stability.h"
#include "lrf/video/mp4_writer.h"

namespace fs = std::filesystem;

namespace lrf::video {

PathVideoResult render_path_video(FieldFrames& frames, const std::vector<Camera>& path, const PathVideoOptions& o) {
  if (path.empty()) fail("the camera path has no frames");
  if (o.video.empty() && o.frames_dir.empty()) fail("nothing to write: give a video file or a frames folder");
  if (!o.video.empty() && fs::path(o.video).extension() != ".mp4") fail(o.video, "the video must be an .mp4 file");
  const int width = path.front().width, height = path.front().height;
  for (const auto& c : path)
    if (c.width != width || c.height != height) fail("the camera path's frames differ in size");
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<Mp4Writer> writer;
  if (!o.video.empty()) writer = std::make_unique<Mp4Writer>(o.video, width, height, o.fps);
  if (!o.frames_dir.empty()) fs::create_directories(o.frames_dir);
  PathVideoResult result;
  detail::FrameStability stability;
  Progress progress("video", static_cast<long>(path.size()));
  for (size_t k = 0; k < path.size(); ++k) {
    FrameTiming timing;
    const cv::Mat frame = frames.render(path[k], &timing);
    result.render_seconds += timing.render_ms / 1000.0;
    result.decode_seconds += timing.decode_ms / 1000.0;
    result.detail_seconds += timing.detail_ms / 1000.0;
    if (o.stability) stability.add(frame, frames.depth(path[k]), path[k]);
    if (writer) writer->write(frame);
    if (!o.frames_dir.empty()) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%04zu.png", k);
      write_image_rgb((fs::path(o.frames_dir) / name).string(), frame);
    }
    progress.update(static_cast<long>(k + 1));
  }
  if (writer) {
    writer->finish();
    result.codec = writer->codec();
  }
  result.frames = static_cast<long>(path.size());
  if (o.stability) result.warp_error = stability.mean_warp_error();
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  progress.finish({{"fps", double(result.frames) / result.seconds}});
  return result;
}

}  // namespace lrf::video
