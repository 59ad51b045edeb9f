#pragma once
// What a finished job tells its user to run next: the commands that look at a trained field.
#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "lrf/core/log.h"

namespace lrf::cli {

// `verb` is what the job just did ("trained", "refined", "scored").
inline void log_next_steps(const std::string& out, const std::string& verb) {
  const std::string q = out.find(' ') == std::string::npos ? out : "'" + out + "'";
  std::vector<std::pair<std::string, std::string>> lines;
  if (verb != "scored") lines.push_back({"lrf eval " + q, "scores the test views"});
  lines.push_back({"lrf render " + q + " --path spiral --video spiral.mp4", "a video (--path orbit for an object scene)"});
  lines.push_back({"lrf serve " + q, "look around in the browser"});
  size_t width = 0;
  for (const auto& l : lines) width = std::max(width, l.first.size());
  std::string next;
  for (const auto& l : lines) next += "\n  " + l.first + std::string(width - l.first.size() + 3, ' ') + "# " + l.second;
  log_info(out + " " + verb + "; next:" + next);
}

}  // namespace lrf::cli
