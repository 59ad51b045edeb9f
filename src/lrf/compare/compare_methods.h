#pragma once
// The methods lrf compare knows, one row each: the job that trains it and what sets it apart from the
// others trained by the same job. run_compare, its plan lines and the efficiency table read a method here
// instead of testing its name.
#include <string>
#include <vector>

#include "lrf/splat/run/field_kind.h"

namespace lrf {

enum class CompareJob {
  rgb_field,        // an RGB Gaussian field (train_rgb_field)
  latent_field,     // the latent field, decoded (the paper's 3DGS-VAE)
  refined_latent,   // the latent field refined through the decoder (lrf refine)
  feature_field,    // a feature field lifted to the latent by a 1x1 convolution (Feature-GS)
  latent_nerf,      // the hash-grid latent NeRF
};

struct CompareMethod {
  std::string name;
  CompareJob job;
  FieldKind kind;     // of the folder it leaves
  int rgb_factor = 0; // rgb_field: the views reduced by this factor (1: full resolution)
  bool mip = false;   // rgb_field: Mip-Splatting's filters
  bool detail = false;  // refined_latent: scored with the detail pass (detail/), on latent-refined's field
};

// Every method, in the order the help lists them: rgb, rgb-mip, rgb/8, rgb/8-mip, latent, latent-refined,
// latent-refined+detail, latent-nerf, feature-gs.
const std::vector<CompareMethod>& compare_method_table();
// The method called `name`; throws lrf::Error naming it and the choices otherwise.
const CompareMethod& compare_method(const std::string& name);

}  // namespace lrf
