#include "lrf/core/precision.h"

#include <atomic>
#include <cstdlib>

#include "lrf/core/cpu_features.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

// -1: not set by the program (fall back to the environment).
std::atomic<int> g_default{-1};

}  // namespace

Precision parse_precision(const std::string& text, const std::string& source) {
  if (text == "fp32") return Precision::fp32;
  if (text == "bf16") return Precision::bf16;
  if (text == "auto") return Precision::automatic;
  fail(source + ": unknown precision '" + text + "' (allowed: fp32, bf16, auto)");
}

std::string precision_name(Precision p) {
  switch (p) {
    case Precision::fp32:
      return "fp32";
    case Precision::bf16:
      return "bf16";
    case Precision::automatic:
      break;
  }
  return "auto";
}

Precision resolve_precision(Precision p) {
  if (p != Precision::automatic) return p;
  return cpu_has_bf16() ? Precision::bf16 : Precision::fp32;
}

Precision default_precision() {
  const int set = g_default.load();
  if (set >= 0) return static_cast<Precision>(set);
  if (const char* env = std::getenv("LRF_PRECISION"); env && *env) return parse_precision(env, "LRF_PRECISION");
  return Precision::automatic;
}

void set_default_precision(Precision p) { g_default.store(static_cast<int>(p)); }

}  // namespace lrf
