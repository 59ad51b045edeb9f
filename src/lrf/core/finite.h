#pragma once
// Numbers read from files must be finite: a NaN or an infinity passes every later comparison (NaN > 0 and
// NaN < 0 are both false) and spreads through every computation, so that e.g. a NaN camera position
// trains a field on nothing and still "succeeds". Readers check what they read with require_finite.
#include <string>

namespace lrf {

// Throws lrf::Error(path, "<where>: <what> is <value>") unless `value` is finite; `where` names the
// record (a view, a camera), `what` the value.
void require_finite(double value, const std::string& path, const std::string& where, const std::string& what);

// A scene coordinate (a camera position or translation, a point) larger than this is a damaged number,
// not a capture: 1e9 is a million kilometres in metres, and float32, which fields train in, keeps no
// detail of a scene that far from its origin. A camera at 1e308 used to surface only as "training
// diverged".
constexpr double kMaxSceneCoordinate = 1e9;

// require_finite, and within +-kMaxSceneCoordinate.
void require_coordinate(double value, const std::string& path, const std::string& where, const std::string& what);

}  // namespace lrf
