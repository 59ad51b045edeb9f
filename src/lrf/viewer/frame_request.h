#pragma once
// The viewer's frame requests: GET /api/frame?client=ID&seq=N&w=W&h=H&fx=..&fy=..&cx=..&cy=..&r=R00,..,R22&t=tx,ty,tz
// (a world-to-camera pose in lrf's convention, R row-major). Everything a browser sends is checked here
// before it reaches the renderer: a missing, repeated, malformed, non-finite or absurd value (a rotation
// that is not one, a camera far outside the scene, a frame too large, a field of view beyond 1..170
// degrees) is an lrf::Error whose message the server returns with status 400.
#include <map>
#include <string>

#include "lrf/scene/camera.h"

namespace lrf::viewer {

struct ViewLimits {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  // the scene's centre
  double radius = 1;       // its size: cameras farther than kMaxDistanceInRadii radii from the centre are refused
  int size_multiple = 1;   // frame sizes must be multiples of this (8 for latent fields)
  int max_side = 2048;     // largest frame width or height
};
constexpr double kMaxDistanceInRadii = 100.0;
constexpr size_t kMaxClientIdLength = 64;

struct FrameRequest {
  std::string client;  // the browser tab's id: letters, digits, '-' and '_'
  long long seq = 0;   // the tab's request counter: a newer request makes its older ones stale
  Camera camera;       // validated; R re-orthonormalised
};

using QueryParams = std::multimap<std::string, std::string>;

FrameRequest parse_frame_request(const QueryParams& params, const ViewLimits& limits);

}  // namespace lrf::viewer
