#include "lrf/frames/test_view_scores.h"

#include <chrono>
#include <filesystem>

#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/progress.h"
#include "lrf/eval/scores.h"

namespace fs = std::filesystem;

namespace lrf {

nlohmann::json score_frames_on_test_views(FieldFrames& frames, const std::string& image_dir, const Lpips* lpips) {
  const Scene& scene = frames.scene();
  if (scene.test_indices.empty()) fail(scene.root, "the scene has no test views");
  if (!image_dir.empty()) fs::create_directories(image_dir);
  std::vector<ImageScores> scores;
  nlohmann::json views = nlohmann::json::array();
  FrameTiming total;
  double frame_seconds = 0;
  Progress progress("eval", static_cast<long>(scene.test_indices.size()));
  for (size_t k = 0; k < scene.test_indices.size(); ++k) {
    const View& v = scene.views[static_cast<size_t>(scene.test_indices[k])];
    FrameTiming timing;
    const auto t0 = std::chrono::steady_clock::now();
    const cv::Mat frame = frames.render(v.camera, &timing);
    frame_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    total.render_ms += timing.render_ms;
    total.decode_ms += timing.decode_ms;
    total.detail_ms += timing.detail_ms;
    const ImageScores s = score_image(scene.load_image(scene.test_indices[k]), frame, lpips, v.name);
    scores.push_back(s);
    auto j = scores_json(s);
    j["name"] = v.name;
    views.push_back(j);
    if (!image_dir.empty()) write_image_rgb((fs::path(image_dir) / (fs::path(v.name).stem().string() + ".png")).string(), frame);
    progress.update(static_cast<long>(k + 1), {{"psnr", s.psnr}});
  }
  const double n = static_cast<double>(scores.size());
  const ImageScores mean = mean_scores(scores);
  nlohmann::json metrics = scores_json(mean);
  metrics["views"] = views;
  metrics["render_ms"] = total.render_ms / n;
  metrics["decode_ms"] = total.decode_ms / n;
  metrics["detail_ms"] = total.detail_ms / n;
  metrics["frame_fps"] = n / std::max(frame_seconds, 1e-9);
  progress.finish({{"psnr", mean.psnr}, {"ssim", mean.ssim}});
  return metrics;
}

}  // namespace lrf
