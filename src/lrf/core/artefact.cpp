#include "lrf/core/artefact.h"

#include "lrf/core/error.h"
#include "lrf/core/run_info.h"

namespace lrf {

void require_same_settings(const std::string& record, const nlohmann::json& recorded, const nlohmann::json& wanted,
                           const std::string& subject, const std::string& remedy) {
  const std::string differ = differing_settings(recorded, wanted);
  if (!differ.empty()) fail(record, subject + " made with other settings:" + differ + "; " + remedy);
}

bool finished_as_wanted(const ArtefactLife& life) {
  if (!life.finished()) return false;
  require_same_settings(life.record, life.recorded(), life.wanted, life.what + " in this folder was", life.remedy);
  return true;
}

ArtefactFate ensure_artefact(const ArtefactLife& life) {
  if (finished_as_wanted(life)) return ArtefactFate::reused;
  const bool resume = life.resumable();
  life.make(resume);
  return resume ? ArtefactFate::resumed : ArtefactFate::made;
}

}  // namespace lrf
