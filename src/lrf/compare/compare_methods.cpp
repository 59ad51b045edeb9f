#include "lrf/compare/compare_methods.h"

#include "lrf/core/error.h"

namespace lrf {

const std::vector<CompareMethod>& compare_method_table() {
  static const std::vector<CompareMethod> table = {
      {"rgb", CompareJob::rgb_field, FieldKind::rgb, 1, false},
      {"rgb-mip", CompareJob::rgb_field, FieldKind::rgb, 1, true},
      {"rgb/8", CompareJob::rgb_field, FieldKind::rgb, 8, false},
      {"rgb/8-mip", CompareJob::rgb_field, FieldKind::rgb, 8, true},
      {"latent", CompareJob::latent_field, FieldKind::latent},
      {"latent-refined", CompareJob::refined_latent, FieldKind::latent},
      {"latent-refined+detail", CompareJob::refined_latent, FieldKind::latent, 0, false, true},
      {"latent-nerf", CompareJob::latent_nerf, FieldKind::latent_nerf},
      {"feature-gs", CompareJob::feature_field, FieldKind::latent},
  };
  return table;
}

const CompareMethod& compare_method(const std::string& name) {
  std::string names;
  for (const auto& m : compare_method_table()) {
    if (m.name == name) return m;
    names += (names.empty() ? "" : ", ") + m.name;
  }
  // Method names come from --methods: an unknown one is a usage error (exit 2), found before any work.
  fail_usage("--methods: unknown method '" + name + "' (" + names + ")");
}

}  // namespace lrf
