// lrf scene info | synth: inspect a scene as lrf reads it; write the built-in synthetic scene.
#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include "command.h"
#include "lrf/core/log.h"
#include "lrf/points/initial_points.h"
#include "lrf/scene/reprojection.h"
#include "lrf/scene/scene.h"
#include "lrf/scene/synthetic_scene.h"
#include "scene_options.h"

namespace {

struct InfoOptions {
  std::string scene;
  lrf::SceneOptions scene_options;
  bool json = false;
};

nlohmann::json describe(const lrf::Scene& s) {
  const lrf::Camera& c = s.views.front().camera;
  nlohmann::json j = {{"format", s.format},          {"views", s.views.size()},     {"train", s.train_indices.size()},
          {"test", s.test_indices.size()}, {"test_indices", s.test_indices}, {"width", c.width},
          {"height", c.height},          {"fx", c.fx},                  {"fy", c.fy},
          {"cx", c.cx},                  {"cy", c.cy},                  {"points", s.points.size()},
          {"tracks", s.has_tracks},      {"extent", s.camera_extent()}};
  // Where a field trained on this scene at this resolution would take its initial points from.
  lrf::InitialPoints init = lrf::describe_initial_points(s, lrf::InitPointsOptions{});
  j["points_source"] = init.source;
  j["points_from"] = init.description;
  if (s.has_tracks) {
    lrf::ReprojectionStats r = lrf::reprojection_error(s);
    j["observations"] = r.observations;
    j["reprojection_median_px"] = r.median_px;
    j["reprojection_mean_px"] = r.mean_px;
  }
  return j;
}

int run_info(const InfoOptions& o) {
  lrf::Scene s = lrf::load_scene(o.scene, o.scene_options);
  nlohmann::json j = describe(s);
  if (o.json) {
    std::printf("%s\n", j.dump().c_str());
    return 0;
  }
  std::printf("scene      %s\nformat     %s\nviews      %zu (%zu train, %zu test)\n", o.scene.c_str(),
              s.format.c_str(), s.views.size(), s.train_indices.size(), s.test_indices.size());
  std::printf("resolution %dx%d (first view)\nintrinsics fx %.3f fy %.3f cx %.3f cy %.3f\n", s.views[0].camera.width,
              s.views[0].camera.height, s.views[0].camera.fx, s.views[0].camera.fy, s.views[0].camera.cx,
              s.views[0].camera.cy);
  std::printf("points     %zu\ninit from  %s: %s\ntracks     %s\nextent     %.4f\n", s.points.size(),
              j["points_source"].get<std::string>().c_str(), j["points_from"].get<std::string>().c_str(),
              s.has_tracks ? "yes" : "no", s.camera_extent());
  if (s.has_tracks) {
    std::printf("reprojection median %.4f px, mean %.4f px over %zu observations\n",
                j["reprojection_median_px"].get<double>(), j["reprojection_mean_px"].get<double>(),
                j["observations"].get<size_t>());
  }
  std::printf("test views");
  for (int i : s.test_indices) std::printf(" %s", s.views[i].name.c_str());
  std::printf("\n");
  return 0;
}

lrf::cli::CommandRegistration reg(10, [](CLI::App& root) {
  auto* scene = root.add_subcommand("scene", "Inspect scenes (COLMAP, LLFF, NeRF transforms.json) and make synthetic ones");
  scene->require_subcommand(1);

  auto* info = scene->add_subcommand("info", "Print what lrf reads from a scene: format, views, split, cameras, points");
  auto io = std::make_shared<InfoOptions>();
  info->add_option("scene", io->scene, "Scene folder")->required();
  lrf::cli::add_scene_options(info, &io->scene_options);
  info->add_flag("--json", io->json, "Print one JSON object (keys: format, views, train, test, test_indices, "
                                     "width, height, fx, fy, cx, cy, points, points_source (file, triangulated or "
                                     "random: where lrf train would take its initial points from at these scene "
                                     "options), points_from, tracks, extent, and with tracks observations, "
                                     "reprojection_median_px, reprojection_mean_px)");
  lrf::cli::on_run(info, [io] { return run_info(*io); });

  auto* synth = scene->add_subcommand("synth", "Render the built-in synthetic scene (COLMAP text format, with "
                                               "points and tracks) to a folder");
  auto so = std::make_shared<lrf::SyntheticOptions>();
  auto out = std::make_shared<std::string>();
  synth->add_option("-o,--output", *out, "Output folder (must not exist or be empty)")->required();
  synth->add_option("--views", so->views, "Number of views")->capture_default_str();
  synth->add_option("--size", so->size, "Image size WxH")->capture_default_str();
  synth->add_option("--seed", so->seed, "Random seed (texture phases, camera jitter)")->capture_default_str();
  synth->add_option("--points", so->points, "SfM points sampled on the surfaces")->capture_default_str();
  lrf::cli::on_run(synth, [so, out] {
    lrf::write_synthetic_scene(*out, *so);
    lrf::log_info("wrote synthetic scene to " + *out);
    return 0;
  });
});

}  // namespace
