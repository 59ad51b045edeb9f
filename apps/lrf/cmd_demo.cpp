// lrf demo: the built-in end-to-end run on the synthetic scene, needing no download.
#include <filesystem>
#include <cstdio>
#include <memory>

#include "command.h"
#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/resolve.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/compare/compare.h"
#include "lrf/core/log.h"
#include "lrf/core/run_info.h"
#include "lrf/scene/reprojection.h"
#include "lrf/scene/scene.h"
#include "lrf/scene/synthetic_scene.h"

namespace fs = std::filesystem;

namespace {

struct DemoOptions {
  std::string output = "out/demo";
  std::string autoencoder = "taef2";
  int64_t iters = 2000;
  bool force = false;
};

int run_demo(const DemoOptions& o) {
  if (fs::exists(o.output) && !fs::is_empty(o.output)) {
    if (!o.force) lrf::fail(o.output, "output folder exists and is not empty (use --force to replace it)");
    fs::remove_all(o.output);
  }
  fs::create_directories(o.output);
  std::string scene_dir = (fs::path(o.output) / "scene").string();
  lrf::SyntheticOptions synth;
  lrf::log_info("demo: rendering the synthetic scene (" + std::to_string(synth.views) + " views, " + synth.size +
                ") to " + scene_dir);
  lrf::write_synthetic_scene(scene_dir, synth);
  lrf::Scene scene = lrf::load_scene(scene_dir);
  lrf::ReprojectionStats r = lrf::reprojection_error(scene);
  lrf::log_info("demo: read back " + std::to_string(scene.views.size()) + " views (" +
                std::to_string(scene.train_indices.size()) + " train, " + std::to_string(scene.test_indices.size()) +
                " test), " + std::to_string(scene.points.size()) + " points, median reprojection error " +
                std::to_string(r.median_px) + " px over " + std::to_string(r.observations) + " observations");
  lrf::write_json_file((fs::path(o.output) / "config.json").string(),
                       lrf::run_record({{"scene", scene_dir}, {"views", synth.views}, {"size", synth.size},
                                        {"autoencoder", o.autoencoder}, {"iters", o.iters}}));
  try {
    lrf::resolve_autoencoder(o.autoencoder);
  } catch (const lrf::Error& e) {
    lrf::fail(std::string(e.what()) + "\nThe demo needs the TAEF2 weights: run scripts/fetch-models.sh (or set "
              "LRF_MODELS to a folder holding taef2/taef2_encoder.pth and taef2_decoder.pth)");
  }
  lrf::CompareOptions c;
  c.scene = scene_dir;
  c.out = (fs::path(o.output) / "compare").string();
  c.autoencoder = o.autoencoder;
  c.iters = o.iters;
  c.methods = {"rgb/8", "latent"};
  c.cache_dir = (fs::path(o.output) / "cache").string();
  lrf::run_compare(c);
  std::printf("%s", lrf::read_file(c.out + "/table.md").c_str());
  lrf::log_info("demo: done; open " + c.out + "/report.html in a browser");
  return 0;
}

lrf::cli::CommandRegistration reg(1, [](CLI::App& root) {
  auto* demo = root.add_subcommand("demo", "Built-in demo: render the synthetic scene, fit rgb/8 and latent (TAEF2) fields, write the table and an HTML report");
  auto o = std::make_shared<DemoOptions>();
  demo->add_option("-o,--output", o->output, "Output folder")->capture_default_str();
  demo->add_option("--autoencoder", o->autoencoder, "Autoencoder of the latent field")->capture_default_str();
  demo->add_option("--iters", o->iters, "Training steps per field")->capture_default_str();
  demo->add_flag("--force", o->force, "Replace the output folder if it exists");
  lrf::cli::on_run(demo, [o] { return run_demo(*o); });
});

}  // namespace
