#pragma once
// Where each artefact of a pipeline folder lives. Stage I, Stage III and the training scenes' fields are
// shared by every evaluation protocol; the evaluation scenes' fields, scores and the tables carry the
// protocol in their names ("" for every training view, "-3views" for the 3-view split), so the few-shot
// table is made beside the full one from the same Stage I and Stage III.
#include <string>

namespace lrf {

// A scene's folder name (of its canonical path).
std::string scene_name(const std::string& root);

// "" for every training view, "-Kviews" for a K-view split.
std::string protocol_suffix(int train_views);

struct PipelinePaths {
  std::string root;
  std::string protocol;  // protocol_suffix(eval_train_views)

  // A training scene's field with the stock encoder ("stock") or the Stage I one ("ft").
  std::string field(const std::string& scene, const std::string& tag) const;
  // An evaluation scene's field of this protocol (tag: stock, ft, stock-refined, rgb8, ...).
  std::string eval_field(const std::string& scene, const std::string& tag) const;
  std::string encoder() const;
  std::string decoder(const std::string& tag) const;
  // The folder of a row's scores and test-view images.
  std::string eval(const std::string& scene, const std::string& row) const;
  // An evaluation scene's name in folders and tables: its folder name and the protocol.
  std::string eval_label(const std::string& scene) const;
  // A table, report or record of this protocol: DIR/<stem><protocol>.<extension>.
  std::string output(const std::string& stem, const std::string& extension) const;
};

}  // namespace lrf
