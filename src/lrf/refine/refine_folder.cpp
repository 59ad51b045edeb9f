#include "lrf/refine/refine_folder.h"

#include <cstdint>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "lrf/core/artefact.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/run_info.h"
#include "lrf/splat/run/train_run.h"

namespace fs = std::filesystem;

namespace lrf {

bool ensure_refined_field(RefineOptions options, const std::string& what, const std::string& remedy, bool start_over) {
  RefineOptions r = with_refine_steps(options);
  const std::string config = (fs::path(r.out) / "config.json").string();
  if (!start_over && splat::run_finished(r.out)) {
    const nlohmann::json recorded = read_json_file(config);
    const nlohmann::json refine = recorded.value("refine", nlohmann::json::object());
    const int64_t done = recorded.value("result", nlohmann::json::object()).value("steps", int64_t(0));
    const bool extendable = r.lr_final == 1 && done < r.steps;
    require_same_settings(config,
                          {{"refine", refine.value("resume_key", nlohmann::json())},
                           {"steps", extendable ? int64_t(r.steps) : done}},
                          {{"refine", refine_resume_key(r)}, {"steps", r.steps}}, what + " in this folder was", remedy);
    if (!extendable) {
      log_info("reusing refined field " + r.out);
      return false;
    }
    log_info("continuing refined field " + r.out + " from step " + std::to_string(done) + " to " +
             std::to_string(r.steps));
    r.resume = true;
    r.force = false;
    refine_latent_field(r);
    return true;
  }
  r.resume = !start_over && fs::exists(splat::checkpoint_path(r.out)) && fs::exists(config);
  r.force = !r.resume;
  log_info("== refine " + r.run + " -> " + r.out + (r.resume ? " (resuming)" : ""));
  refine_latent_field(r);
  return true;
}

}  // namespace lrf
