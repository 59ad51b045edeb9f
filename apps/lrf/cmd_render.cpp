// lrf render: images of a trained field for the scene's cameras, at any resolution.
#include <filesystem>
#include <functional>
#include <memory>

#include "command.h"
#include "lrf/autoencoder/image_tensor.h"
#include "lrf/core/safetensors.h"
#include "lrf/latent/latent_field.h"
#include "lrf/latent/latent_run.h"
#include "lrf/nerf/nerf_run.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/splat/run/run_folder.h"
#include "lrf/rgb/rgb_field.h"

namespace fs = std::filesystem;

namespace {

struct RenderOptions {
  std::string out;
  std::string split = "test";
  std::string dir;
  double scale = 1.0;
  int width = 0, height = 0;
  std::string decoder;  // latent fields: decoder override (Stage III)
};

// Latent fields and latent NeRFs: the rendered latents (denormalised, safetensors, one tensor "latent"
// [C, h, w] per view) and the decoded images, at the training latent resolution. `render_view(i)` gives view
// i's normalised latent.
int run_render_latent(const RenderOptions& o, const std::vector<int>& indices, const lrf::Scene& scene,
                      const lrf::LatentRange& range, lrf::Autoencoder& ae,
                      const std::function<torch::Tensor(int)>& render_view, const std::string& dir) {
  using namespace lrf;
  if (o.scale != 1.0 || o.width > 0) fail("--scale/--width/--height apply to RGB fields; latent fields render at "
                                          "their latent resolution and decode at 8x");
  Progress progress("render", static_cast<long>(indices.size()));
  long done = 0;
  for (int i : indices) {
    const auto& view = scene.views[static_cast<size_t>(i)];
    auto zn = render_view(i);
    const std::string stem = (fs::path(dir) / fs::path(view.name).stem()).string();
    StateDict latent;
    latent.insert("latent", range.denormalize(zn).contiguous());
    write_safetensors(stem + ".safetensors", latent, {{"view", view.name}, {"space", "raw latent"}});
    write_image_rgb(stem + ".png", tensor_to_image(decode_normalised(ae, range, zn)));
    progress.update(++done);
  }
  progress.finish();
  log_info("wrote " + std::to_string(indices.size()) + " latents (.safetensors) and decoded images to " + dir);
  return 0;
}

int run_render(const RenderOptions& o) {
  using namespace lrf;
  using namespace lrf::splat;
  if ((o.width > 0) != (o.height > 0)) fail("--width and --height go together");
  const bool nerf_field = nerf::is_nerf_run(o.out);
  const bool latent = !nerf_field && is_latent_run(o.out);
  LatentRun lrun;
  nerf::NerfRun nrun;
  FieldRun run;
  if (nerf_field) {
    nrun = nerf::open_nerf_run(o.out);
    run.scene = nrun.scene;
  } else if (latent) {
    lrun = open_latent_run(o.out);
    run.scene = lrun.scene;
  } else {
    if (!o.decoder.empty()) fail("--decoder applies to latent fields");
    run = open_field_run(o.out);
  }
  std::vector<int> indices;
  if (o.split == "test") indices = run.scene.test_indices;
  else if (o.split == "train") indices = run.scene.train_indices;
  else if (o.split == "all") for (size_t i = 0; i < run.scene.views.size(); ++i) indices.push_back(int(i));
  else fail("--split must be test, train or all");
  if (indices.empty()) fail(o.out, "the '" + o.split + "' split has no views");
  const std::string dir = o.dir.empty() ? (fs::path(o.out) / "renders" / o.split).string() : o.dir;
  fs::create_directories(dir);
  if (nerf_field) {
    auto ae = load_autoencoder(nrun.autoencoder, nrun.encoder, o.decoder);
    return run_render_latent(o, indices, nrun.scene, nrun.range, *ae,
                             [&](int i) { return nerf::render_nerf_latent(nrun, i); }, dir);
  }
  if (latent) {
    auto ae = load_autoencoder(lrun.autoencoder, lrun.encoder, o.decoder.empty() ? lrun.decoder : o.decoder);
    return run_render_latent(o, indices, lrun.scene, lrun.range, *ae, [&](int i) { return render_latent(lrun, i); },
                             dir);
  }
  Progress progress("render", static_cast<long>(indices.size()));
  long done = 0;
  for (int i : indices) {
    const auto& view = run.scene.views[static_cast<size_t>(i)];
    auto camera = scaled_camera(view.camera, o.scale, o.width, o.height);
    auto image = render_field(run.field, camera, run.render).image;
    write_image_rgb((fs::path(dir) / (fs::path(view.name).stem().string() + ".png")).string(), splat::tensor_to_image(image));
    progress.update(++done);
  }
  progress.finish();
  log_info("wrote " + std::to_string(indices.size()) + " images to " + dir);
  return 0;
}

lrf::cli::CommandRegistration reg(21, [](CLI::App& root) {
  auto* cmd = root.add_subcommand("render", "Render a trained field (lrf train output): PNG images; latent fields and latent NeRFs also write the rendered latents");
  auto o = std::make_shared<RenderOptions>();
  cmd->add_option("out", o->out, "Output folder of lrf train")->required();
  cmd->add_option("--split", o->split, "Which views: test, train or all")->capture_default_str();
  cmd->add_option("-o,--dir", o->dir, "Folder for the images (default OUT/renders/SPLIT)");
  auto* scale = cmd->add_option("--scale", o->scale, "Resolution relative to training")->capture_default_str();
  cmd->add_option("--width", o->width, "Render width in pixels (with --height)")->excludes(scale);
  cmd->add_option("--height", o->height, "Render height in pixels (with --width)")->excludes(scale);
  cmd->add_option("--decoder", o->decoder, "Latent fields and latent NeRFs: decode with these decoder weights (e.g. Stage III's; default: the decoder "
                  "a refined field was fitted through, else the autoencoder's)");
  lrf::cli::on_run(cmd, [o] { return run_render(*o); });
});

}  // namespace
