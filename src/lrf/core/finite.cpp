#include "lrf/core/finite.h"

#include <cmath>

#include "lrf/core/error.h"

namespace lrf {

void require_finite(double value, const std::string& path, const std::string& where, const std::string& what) {
  if (std::isfinite(value)) return;
  fail(path, where + ": " + what + " is " + (std::isnan(value) ? "NaN" : value > 0 ? "+infinity" : "-infinity") +
                 ", not a finite number");
}

}  // namespace lrf
