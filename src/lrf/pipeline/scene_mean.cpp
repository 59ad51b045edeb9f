#include "lrf/pipeline/scene_mean.h"

#include <map>

namespace lrf {
namespace {

std::string text_of(const Cell& c) { return c.kind == Cell::Kind::text ? c.text : display_text(c); }

}  // namespace

SceneMean mean_over_scenes(const std::vector<std::string>& header, const std::vector<Row>& rows,
                           const std::vector<std::string>& scenes, const std::vector<std::string>& methods) {
  // (method, scene) -> that scene's row of the method.
  std::map<std::pair<std::string, std::string>, const Row*> by_key;
  for (const Row& r : rows) {
    if (r.size() >= 2) by_key[{text_of(r[1]), text_of(r[0])}] = &r;
  }
  SceneMean mean;
  for (const std::string& method : methods) {
    std::vector<const Row*> per_scene;
    std::string lacking;
    for (const std::string& scene : scenes) {
      const auto it = by_key.find({method, scene});
      if (it == by_key.end()) {
        lacking += (lacking.empty() ? "" : ", ") + scene;
      } else {
        per_scene.push_back(it->second);
      }
    }
    if (per_scene.size() != scenes.size()) {
      // A method no scene has (a row this run did not make) is not a gap in the table.
      if (!per_scene.empty()) mean.left_out.push_back(method + ": no row for " + lacking);
      continue;
    }
    if (scenes.empty()) continue;
    Row row = {Cell("mean"), Cell(method)};
    for (size_t c = 2; c < header.size(); ++c) {
      double sum = 0;
      std::string without;
      size_t with = 0;
      for (size_t s = 0; s < per_scene.size(); ++s) {
        const Row& r = *per_scene[s];
        if (c < r.size() && r[c].kind == Cell::Kind::number) {
          sum += r[c].number;
          ++with;
        } else {
          without += (without.empty() ? "" : ", ") + scenes[s];
        }
      }
      if (with == per_scene.size()) {
        row.push_back(Cell(sum / static_cast<double>(with)));
      } else {
        row.push_back(Cell());
        if (with > 0) mean.left_out.push_back(method + ": " + header[c] + " missing for " + without);
      }
    }
    mean.rows.push_back(std::move(row));
  }
  return mean;
}

}  // namespace lrf
