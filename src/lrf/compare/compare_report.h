#pragma once
// What `lrf compare` writes once every method is scored: table.csv/.md (quality), efficiency.csv/.md (the
// paper's Table 5 columns), and report.html with both tables, the notes, the quality-against-time chart
// and every test view.
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/compare/compare.h"
#include "lrf/scene/scene.h"

namespace lrf {

// A method's folder under the compare folder ('/' in its name becomes '_').
std::string compare_method_dir(const std::string& method);

// `all`: each method's scores (its metrics.json), by name. `scene` is the scene as scored (its test views).
void write_compare_outputs(const CompareOptions& o, const nlohmann::json& all, const Scene& scene);

}  // namespace lrf
