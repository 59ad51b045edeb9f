#pragma once
// The life of an artefact that a longer job makes once and reuses (compare's methods, the pipeline's
// stages, fields and refinements): reused when it is finished and was made with the settings asked for,
// refused — naming each setting that differs — when it was made with others, else continued from its
// checkpoint, else made from the start. Written once here, so that every stage decides alike.
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

namespace lrf {

// Throws lrf::Error naming `record`: "<subject> made with other settings: key (recorded vs wanted)...;
// <remedy>", when `recorded` lacks or differs in a setting of `wanted`.
void require_same_settings(const std::string& record, const nlohmann::json& recorded, const nlohmann::json& wanted,
                           const std::string& subject, const std::string& remedy);

struct ArtefactLife {
  std::string what;    // e.g. "the field", for messages ("the field in this folder was made with other settings")
  std::string record;  // the file whose recorded settings are compared, named in a refusal
  std::string remedy;  // e.g. "use another output folder or remove DIR"
  std::function<bool()> finished;
  std::function<nlohmann::json()> recorded;  // the finished artefact's settings, as `wanted` names them
  nlohmann::json wanted;
  std::function<bool()> resumable;  // a checkpoint to continue from
  std::function<void(bool resume)> make;
};

// True when the artefact is finished and was made with the settings asked for; throws (require_same_settings)
// when it is finished but was made with others.
bool finished_as_wanted(const ArtefactLife& life);

enum class ArtefactFate { reused, resumed, made };

ArtefactFate ensure_artefact(const ArtefactLife& life);

}  // namespace lrf
