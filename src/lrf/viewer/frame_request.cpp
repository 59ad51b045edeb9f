#include "lrf/viewer/frame_request.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <vector>

#include <Eigen/SVD>

#include "lrf/core/error.h"

namespace lrf::viewer {
namespace {

const std::string& single(const QueryParams& params, const std::string& key) {
  const auto n = params.count(key);
  if (n == 0) fail("frame request: '" + key + "' is missing");
  if (n > 1) fail("frame request: '" + key + "' is given " + std::to_string(n) + " times");
  return params.find(key)->second;
}

// A finite decimal number taking the whole text (no trailing characters, no hex, no inf or nan).
double parse_number(const std::string& key, const std::string& text) {
  if (text.empty() || text.size() > 40) fail("frame request: '" + key + "' is not a number");
  for (char ch : text)
    if (!(std::isdigit(static_cast<unsigned char>(ch)) || ch == '-' || ch == '+' || ch == '.' || ch == 'e' || ch == 'E'))
      fail("frame request: '" + key + "' is not a decimal number: '" + text + "'");
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v))
    fail("frame request: '" + key + "' is not a finite number: '" + text + "'");
  return v;
}

std::vector<double> parse_numbers(const std::string& key, const std::string& text, size_t count) {
  std::vector<double> values;
  size_t start = 0;
  while (values.size() <= count) {
    const size_t comma = text.find(',', start);
    values.push_back(parse_number(key, text.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (values.size() != count)
    fail("frame request: '" + key + "' needs " + std::to_string(count) + " comma-separated numbers");
  return values;
}

int parse_size(const std::string& key, const std::string& text, const ViewLimits& limits) {
  const double v = parse_number(key, text);
  if (v != std::floor(v) || v < limits.size_multiple || v > limits.max_side)
    fail("frame request: '" + key + "' must be a whole number of pixels in " + std::to_string(limits.size_multiple) +
         ".." + std::to_string(limits.max_side) + " (got " + text + ")");
  const int n = static_cast<int>(v);
  if (n % limits.size_multiple)
    fail("frame request: '" + key + "' must be a multiple of " + std::to_string(limits.size_multiple) + " (got " + text + ")");
  return n;
}

}  // namespace

FrameRequest parse_frame_request(const QueryParams& params, const ViewLimits& limits) {
  for (const auto& [key, value] : params) {
    static const char* known[] = {"client", "seq", "w", "h", "fx", "fy", "cx", "cy", "r", "t"};
    bool ok = false;
    for (const char* k : known) ok = ok || key == k;
    if (!ok) fail("frame request: unknown parameter '" + key.substr(0, 32) + "'");
  }
  FrameRequest r;
  r.client = single(params, "client");
  if (r.client.empty() || r.client.size() > kMaxClientIdLength)
    fail("frame request: 'client' must be 1.." + std::to_string(kMaxClientIdLength) + " characters");
  for (char ch : r.client)
    if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' || ch == '_'))
      fail("frame request: 'client' may hold only letters, digits, '-' and '_'");
  const double seq = parse_number("seq", single(params, "seq"));
  if (seq != std::floor(seq) || seq < 0 || seq > 9007199254740992.0)  // 2^53: exact in JavaScript
    fail("frame request: 'seq' must be a whole number in 0..2^53");
  r.seq = static_cast<long long>(seq);

  Camera& c = r.camera;
  c.width = parse_size("w", single(params, "w"), limits);
  c.height = parse_size("h", single(params, "h"), limits);
  c.fx = parse_number("fx", single(params, "fx"));
  c.fy = parse_number("fy", single(params, "fy"));
  c.cx = parse_number("cx", single(params, "cx"));
  c.cy = parse_number("cy", single(params, "cy"));
  // Fields of view between 1 and 170 degrees: tan(0.5 deg) and tan(85 deg) bound the focal length.
  const double lo = 0.5 / std::tan(85.0 * M_PI / 180.0), hi = 0.5 / std::tan(0.5 * M_PI / 180.0);
  if (!(c.fx >= lo * c.width && c.fx <= hi * c.width && c.fy >= lo * c.height && c.fy <= hi * c.height))
    fail("frame request: the focal lengths give a field of view outside 1..170 degrees");
  if (!(c.cx >= -c.width && c.cx <= 2.0 * c.width && c.cy >= -c.height && c.cy <= 2.0 * c.height))
    fail("frame request: the principal point lies more than a frame outside the frame");

  const auto rv = parse_numbers("r", single(params, "r"), 9);
  const auto tv = parse_numbers("t", single(params, "t"), 3);
  Eigen::Matrix3d R;
  R << rv[0], rv[1], rv[2], rv[3], rv[4], rv[5], rv[6], rv[7], rv[8];
  // A browser's rotation carries float rounding; anything further from a rotation is a wrong request.
  const double off = (R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(off < 1e-3) || !(R.determinant() > 0))
    fail("frame request: 'r' is not a rotation matrix (orthonormal with determinant +1)");
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  c.R = svd.matrixU() * svd.matrixV().transpose();
  c.t = Eigen::Vector3d(tv[0], tv[1], tv[2]);
  const double distance = (c.center() - limits.center).norm();
  if (!(distance <= kMaxDistanceInRadii * limits.radius))
    fail("frame request: the camera is " + std::to_string(distance) + " from the scene's centre, more than " +
         std::to_string(kMaxDistanceInRadii) + " times the scene's radius");
  return r;
}

}  // namespace lrf::viewer
