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

#include "lrf/camera_path/camera_path.h"
#include "lrf/pipeline/pipeline.h"
#include "lrf/scene/synthetic_scene.h"

namespace lrf {

// The job's parts at the demo's small sizes (demo.cpp's constructor): a synthetic scene's views and their
// size, the pipeline's autoencoder and step counts (its scenes and folders are the demo's), the video's frames.
struct DemoOptions {
  DemoOptions();
  std::string output = "out/demo";
  SyntheticOptions scenes;         // views per scene and their size (latent fields: 8x smaller); seed: each scene's
  PipelineOptions pipeline;
  camera_path::PathOptions video;  // the orbit video of the both+refine field; frames 0: no video
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
