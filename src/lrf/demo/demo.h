#pragma once
// `lrf demo`: the whole method in miniature, needing no download beyond the TAEF2 weights. Three
// built-in synthetic scenes (the same geometry, different textures and camera rings): Stage I and
// Stage III learn from two of them, and the third, which neither stage sees, is the one judged: its
// rgb/8 and rgb/8-mip baselines, its stock and Stage I latent fields, decoded with the stock and the
// Stage III decoders, and both refined; then the ablation table, report.html and a short video of the
// best row. Everything is `lrf pipeline` at small sizes, so the demo's folder is a pipeline's folder.
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace lrf {

struct DemoOptions {
  std::string output = "out/demo";
  std::string autoencoder = "taef2";
  int views = 24;                 // per synthetic scene
  std::string size = "256x192";   // of the synthetic views (latent fields: 32x24)
  int64_t field_iters = 1500;     // Stage II steps per field (and per RGB baseline)
  int64_t stage1_steps = 100;
  int64_t stage3_steps = 100;
  int64_t refine_steps = 300;
  int video_frames = 48;          // 0: no video
  bool force = false;
};

struct DemoResult {
  std::string table_md;     // the ablation table (Markdown)
  std::string report_html;  // path
  std::string video;        // path ("" without one)
  nlohmann::json pipeline;  // pipeline.json's summary
};

// Writes the scenes under OUTPUT/scenes, the method's folders under OUTPUT/pipeline and the video as
// OUTPUT/video.mp4. Refuses a non-empty OUTPUT unless `force` (then replaces it). Throws lrf::Error.
DemoResult run_demo(const DemoOptions& options);

}  // namespace lrf
