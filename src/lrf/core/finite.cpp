#include "lrf/core/finite.h"

#include <cmath>
#include <cstdio>

#include "lrf/core/error.h"

namespace lrf {

void require_finite(double value, const std::string& path, const std::string& where, const std::string& what) {
  if (std::isfinite(value)) return;
  fail(path, where + ": " + what + " is " + (std::isnan(value) ? "NaN" : value > 0 ? "+infinity" : "-infinity") +
                 ", not a finite number");
}

void require_coordinate(double value, const std::string& path, const std::string& where, const std::string& what) {
  require_finite(value, path, where, what);
  if (std::abs(value) <= kMaxSceneCoordinate) return;
  char text[64];
  std::snprintf(text, sizeof text, "%g", value);
  fail(path, where + ": " + what + " is " + text + ", beyond the +-1e9 any real scene lies within (a damaged file?)");
}

}  // namespace lrf
