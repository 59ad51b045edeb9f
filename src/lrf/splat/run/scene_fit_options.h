#pragma once
// What every fit of a field to one scene shares, whatever the field holds (Gaussians or a NeRF): its output
// folder (RunControl), the scene and which of its views, the length, the seed, the points it starts from
// and the preset its settings came from.
#include <cstdint>
#include <string>

#include "lrf/core/run_control.h"
#include "lrf/points/initial_points.h"
#include "lrf/scene/scene.h"

namespace lrf {

struct SceneFitOptions : RunControl {
  std::string scene;
  SceneOptions scene_options;
  int64_t iters = 30000;
  uint64_t seed = 0;
  InitPointsOptions init_points;   // where the field starts (SfM, triangulated, random, a file)
  std::string preset = "default";  // the --preset the options came from, recorded for --resume
};

}  // namespace lrf
