#include "lrf/scene/colmap_model.h"

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include <Eigen/Geometry>

#include "lrf/core/atomic_file.h"
#include "lrf/core/binary_reader.h"
#include "lrf/core/error.h"
#include "lrf/core/finite.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

struct ModelInfo {
  int id;
  const char* name;
  int num_params;
};

// COLMAP's camera model ids, names and parameter counts (src/colmap/sensor/models.h).
constexpr ModelInfo kModels[] = {
    {0, "SIMPLE_PINHOLE", 3}, {1, "PINHOLE", 4},         {2, "SIMPLE_RADIAL", 4},
    {3, "RADIAL", 5},         {4, "OPENCV", 8},          {5, "OPENCV_FISHEYE", 8},
    {6, "FULL_OPENCV", 12},   {7, "FOV", 5},             {8, "SIMPLE_RADIAL_FISHEYE", 4},
    {9, "RADIAL_FISHEYE", 5}, {10, "THIN_PRISM_FISHEYE", 12},
};

const ModelInfo* model_by_id(int id) {
  for (const auto& m : kModels)
    if (m.id == id) return &m;
  return nullptr;
}

const ModelInfo* model_by_name(const std::string& name) {
  for (const auto& m : kModels)
    if (name == m.name) return &m;
  return nullptr;
}

// Reads non-empty, non-comment lines of a COLMAP text file, keeping empty lines when asked (images.txt
// has an empty 2D-point line for images without keypoints).
std::vector<std::string> data_lines(const std::string& bytes, bool keep_empty) {
  std::istringstream in(bytes);
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!line.empty() && line[0] == '#') continue;
    if (line.empty() && !keep_empty) continue;
    lines.push_back(line);
  }
  return lines;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Intrinsics and poses must be finite numbers (see core/finite.h), and a quaternion must have a length.
void check_camera_values(const ColmapCamera& c, const std::string& path) {
  const std::string where = "camera " + std::to_string(c.id) + " (" + c.model + ")";
  const std::string count = std::to_string(c.params.size());
  for (size_t k = 0; k < c.params.size(); ++k)
    require_finite(c.params[k], path, where, "parameter " + std::to_string(k + 1) + " of " + count);
}

void check_image_pose(const ColmapImage& im, const std::string& path) {
  const std::string where = "image '" + im.name + "' (id " + std::to_string(im.id) + ")";
  static const char* const kQ[] = {"qw", "qx", "qy", "qz"};
  static const char* const kT[] = {"tx", "ty", "tz"};
  for (int k = 0; k < 4; ++k) require_finite(im.qvec[k], path, where, std::string("rotation quaternion ") + kQ[k]);
  for (int k = 0; k < 3; ++k) require_coordinate(im.tvec[k], path, where, std::string("translation ") + kT[k]);
  if (im.qvec.norm() == 0) fail(path, where + ": rotation quaternion is zero");
}

std::map<uint32_t, ColmapCamera> parse_cameras_bin(const std::string& bytes, const std::string& path) {
  BinaryReader r(bytes, path);
  uint64_t n = r.read<uint64_t>();
  r.require_records(n, 24, "cameras");
  std::map<uint32_t, ColmapCamera> cams;
  for (uint64_t i = 0; i < n; ++i) {
    ColmapCamera c;
    c.id = r.read<uint32_t>();
    int model_id = r.read<int32_t>();
    const ModelInfo* m = model_by_id(model_id);
    if (!m) fail(path, "unknown camera model id " + std::to_string(model_id) + " for camera " + std::to_string(c.id));
    c.model = m->name;
    c.width = static_cast<int64_t>(r.read<uint64_t>());
    c.height = static_cast<int64_t>(r.read<uint64_t>());
    if (c.width <= 0 || c.height <= 0 || c.width > 1000000 || c.height > 1000000) {
      fail(path, "corrupt camera " + std::to_string(c.id) + ": size " + std::to_string(c.width) + "x" +
                     std::to_string(c.height));
    }
    for (int k = 0; k < m->num_params; ++k) c.params.push_back(r.read<double>());
    check_camera_values(c, path);
    cams[c.id] = c;
  }
  return cams;
}

std::map<uint32_t, ColmapCamera> parse_cameras_txt(const std::string& bytes, const std::string& path) {
  std::map<uint32_t, ColmapCamera> cams;
  for (const auto& line : data_lines(bytes, false)) {
    std::istringstream s(line);
    ColmapCamera c;
    if (!(s >> c.id >> c.model >> c.width >> c.height)) fail(path, "malformed camera line: " + line);
    const ModelInfo* m = model_by_name(c.model);
    if (!m) fail(path, "unknown camera model '" + c.model + "'");
    double v;
    while (s >> v) c.params.push_back(v);
    if (static_cast<int>(c.params.size()) != m->num_params) {
      fail(path, "camera " + std::to_string(c.id) + " (" + c.model + ") has " + std::to_string(c.params.size()) +
                     " parameters, expected " + std::to_string(m->num_params));
    }
    if (c.width <= 0 || c.height <= 0) fail(path, "camera " + std::to_string(c.id) + " has a non-positive size");
    check_camera_values(c, path);
    cams[c.id] = c;
  }
  return cams;
}

std::vector<ColmapImage> parse_images_bin(const std::string& bytes, const std::string& path) {
  BinaryReader r(bytes, path);
  uint64_t n = r.read<uint64_t>();
  r.require_records(n, 4 + 7 * 8 + 4 + 1 + 8, "images");
  std::vector<ColmapImage> images;
  images.reserve(n);
  for (uint64_t i = 0; i < n; ++i) {
    ColmapImage im;
    im.id = r.read<uint32_t>();
    for (int k = 0; k < 4; ++k) im.qvec[k] = r.read<double>();
    for (int k = 0; k < 3; ++k) im.tvec[k] = r.read<double>();
    im.camera_id = r.read<uint32_t>();
    im.name = r.read_cstring();
    check_image_pose(im, path);
    uint64_t np = r.read<uint64_t>();
    r.require_records(np, 24, "2D points");
    im.xys.resize(np);
    im.point3d_ids.resize(np);
    for (uint64_t k = 0; k < np; ++k) {
      im.xys[k].x() = r.read<double>();
      im.xys[k].y() = r.read<double>();
      im.point3d_ids[k] = r.read<int64_t>();
    }
    images.push_back(std::move(im));
  }
  return images;
}

std::vector<ColmapImage> parse_images_txt(const std::string& bytes, const std::string& path) {
  auto lines = data_lines(bytes, true);
  // Drop trailing empty lines only; inside the file an empty line is an image's empty keypoint list.
  while (!lines.empty() && lines.back().empty()) lines.pop_back();
  std::vector<ColmapImage> images;
  size_t i = 0;
  while (i < lines.size()) {
    if (lines[i].empty()) {
      ++i;
      continue;
    }
    ColmapImage im;
    std::istringstream s(lines[i]);
    if (!(s >> im.id >> im.qvec[0] >> im.qvec[1] >> im.qvec[2] >> im.qvec[3] >> im.tvec[0] >> im.tvec[1] >>
          im.tvec[2] >> im.camera_id >> im.name)) {
      fail(path, "malformed image line: " + lines[i]);
    }
    check_image_pose(im, path);
    ++i;
    if (i < lines.size()) {
      std::istringstream p(lines[i]);
      double x, y;
      int64_t id;
      while (p >> x >> y >> id) {
        im.xys.emplace_back(x, y);
        im.point3d_ids.push_back(id);
      }
      ++i;
    }
    images.push_back(std::move(im));
  }
  return images;
}

// A point's position must be a usable coordinate: one NaN used to make the whole field NaN, reported only
// as "training diverged".
void require_point(const ColmapPoint& p, const std::string& path) {
  for (int k = 0; k < 3; ++k)
    require_coordinate(p.xyz[k], path, "point " + std::to_string(p.id), std::string("coordinate ") + "xyz"[k]);
}

std::vector<ColmapPoint> parse_points_bin(const std::string& bytes, const std::string& path) {
  BinaryReader r(bytes, path);
  uint64_t n = r.read<uint64_t>();
  r.require_records(n, 8 + 24 + 3 + 8 + 8, "points");
  std::vector<ColmapPoint> points;
  points.reserve(n);
  for (uint64_t i = 0; i < n; ++i) {
    ColmapPoint p;
    p.id = static_cast<int64_t>(r.read<uint64_t>());
    for (int k = 0; k < 3; ++k) p.xyz[k] = r.read<double>();
    require_point(p, path);
    for (int k = 0; k < 3; ++k) p.rgb[k] = r.read<uint8_t>() / 255.0f;
    p.error = r.read<double>();
    uint64_t track = r.read<uint64_t>();
    r.require_records(track, 8, "track elements");
    for (uint64_t k = 0; k < track; ++k) {
      r.read<uint32_t>();
      r.read<uint32_t>();
    }
    points.push_back(p);
  }
  return points;
}

std::vector<ColmapPoint> parse_points_txt(const std::string& bytes, const std::string& path) {
  std::vector<ColmapPoint> points;
  for (const auto& line : data_lines(bytes, false)) {
    std::istringstream s(line);
    ColmapPoint p;
    int r, g, b;
    if (!(s >> p.id >> p.xyz[0] >> p.xyz[1] >> p.xyz[2] >> r >> g >> b)) fail(path, "malformed point line: " + line);
    require_point(p, path);
    p.rgb = Eigen::Vector3f(r, g, b) / 255.0f;
    if (!(s >> p.error)) p.error = 0;
    points.push_back(p);
  }
  return points;
}

std::string pick(const std::string& dir, const std::string& stem) {
  for (const char* ext : {".bin", ".txt"}) {
    std::string p = (fs::path(dir) / (stem + ext)).string();
    if (fs::exists(p)) return p;
  }
  return "";
}

}  // namespace

std::map<uint32_t, ColmapCamera> parse_colmap_cameras(const std::string& bytes, const std::string& path, bool text) {
  return text ? parse_cameras_txt(bytes, path) : parse_cameras_bin(bytes, path);
}
std::vector<ColmapImage> parse_colmap_images(const std::string& bytes, const std::string& path, bool text) {
  return text ? parse_images_txt(bytes, path) : parse_images_bin(bytes, path);
}
std::vector<ColmapPoint> parse_colmap_points(const std::string& bytes, const std::string& path, bool text) {
  return text ? parse_points_txt(bytes, path) : parse_points_bin(bytes, path);
}
std::map<uint32_t, ColmapCamera> read_colmap_cameras(const std::string& path) {
  return parse_colmap_cameras(read_file(path), path, ends_with(path, ".txt"));
}
std::vector<ColmapImage> read_colmap_images(const std::string& path) {
  return parse_colmap_images(read_file(path), path, ends_with(path, ".txt"));
}
std::vector<ColmapPoint> read_colmap_points(const std::string& path) {
  return parse_colmap_points(read_file(path), path, ends_with(path, ".txt"));
}

ColmapModel read_colmap_model(const std::string& dir) {
  ColmapModel model;
  std::string cams = pick(dir, "cameras");
  if (cams.empty()) fail(dir, "no cameras.bin or cameras.txt in the COLMAP model folder");
  model.cameras = read_colmap_cameras(cams);
  std::string imgs = pick(dir, "images");
  if (!imgs.empty()) model.images = read_colmap_images(imgs);
  std::string pts = pick(dir, "points3D");
  if (!pts.empty()) model.points = read_colmap_points(pts);
  for (const auto& im : model.images) {
    if (!model.cameras.count(im.camera_id)) {
      fail(imgs, "image '" + im.name + "' refers to missing camera " + std::to_string(im.camera_id));
    }
  }
  return model;
}

namespace {

template <typename T>
void put(std::string* out, T v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof v);
}

uint8_t colour_byte(float v) { return static_cast<uint8_t>(std::lround(std::clamp(v, 0.f, 1.f) * 255.f)); }

std::string points_text(const std::vector<ColmapPoint>& points) {
  std::ostringstream p;
  p << std::setprecision(17) << "# POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[]\n";
  for (const auto& pt : points) {
    p << pt.id << " " << pt.xyz.x() << " " << pt.xyz.y() << " " << pt.xyz.z();
    for (int k = 0; k < 3; ++k) p << " " << int(colour_byte(pt.rgb[k]));
    p << " " << pt.error << "\n";
  }
  return p.str();
}

std::string points_binary(const std::vector<ColmapPoint>& points) {
  std::string p;
  put<uint64_t>(&p, points.size());
  for (const auto& pt : points) {
    put<uint64_t>(&p, static_cast<uint64_t>(pt.id));
    for (int k = 0; k < 3; ++k) put<double>(&p, pt.xyz[k]);
    for (int k = 0; k < 3; ++k) put<uint8_t>(&p, colour_byte(pt.rgb[k]));
    put<double>(&p, pt.error);
    put<uint64_t>(&p, 0);  // track length
  }
  return p;
}

}  // namespace

void write_colmap_points(const std::string& path, const std::vector<ColmapPoint>& points) {
  write_file_atomic(path, ends_with(path, ".txt") ? points_text(points) : points_binary(points));
}

void write_colmap_text(const std::string& dir, const ColmapModel& model) {
  std::ostringstream c, i;
  c << std::setprecision(17) << "# Camera list: CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  for (const auto& [id, cam] : model.cameras) {
    c << id << " " << cam.model << " " << cam.width << " " << cam.height;
    for (double v : cam.params) c << " " << v;
    c << "\n";
  }
  i << std::setprecision(17) << "# IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n# POINTS2D[] as (X, Y, POINT3D_ID)\n";
  for (const auto& im : model.images) {
    i << im.id;
    for (int k = 0; k < 4; ++k) i << " " << im.qvec[k];
    for (int k = 0; k < 3; ++k) i << " " << im.tvec[k];
    i << " " << im.camera_id << " " << im.name << "\n";
    for (size_t k = 0; k < im.xys.size(); ++k) {
      i << (k ? " " : "") << im.xys[k].x() << " " << im.xys[k].y() << " " << im.point3d_ids[k];
    }
    i << "\n";
  }
  write_file_atomic((fs::path(dir) / "cameras.txt").string(), c.str());
  write_file_atomic((fs::path(dir) / "images.txt").string(), i.str());
  write_file_atomic((fs::path(dir) / "points3D.txt").string(), points_text(model.points));
}

void write_colmap_binary(const std::string& dir, const ColmapModel& model) {
  std::string c, i, p;
  put<uint64_t>(&c, model.cameras.size());
  for (const auto& [id, cam] : model.cameras) {
    const ModelInfo* m = model_by_name(cam.model);
    if (!m || static_cast<int>(cam.params.size()) != m->num_params) fail(dir, "cannot write camera model " + cam.model);
    put<uint32_t>(&c, id);
    put<int32_t>(&c, m->id);
    put<uint64_t>(&c, static_cast<uint64_t>(cam.width));
    put<uint64_t>(&c, static_cast<uint64_t>(cam.height));
    for (double v : cam.params) put<double>(&c, v);
  }
  put<uint64_t>(&i, model.images.size());
  for (const auto& im : model.images) {
    put<uint32_t>(&i, im.id);
    for (int k = 0; k < 4; ++k) put<double>(&i, im.qvec[k]);
    for (int k = 0; k < 3; ++k) put<double>(&i, im.tvec[k]);
    put<uint32_t>(&i, im.camera_id);
    i += im.name;
    i.push_back('\0');
    put<uint64_t>(&i, im.xys.size());
    for (size_t k = 0; k < im.xys.size(); ++k) {
      put<double>(&i, im.xys[k].x());
      put<double>(&i, im.xys[k].y());
      put<int64_t>(&i, im.point3d_ids[k]);
    }
  }
  p = points_binary(model.points);
  write_file_atomic((fs::path(dir) / "cameras.bin").string(), c);
  write_file_atomic((fs::path(dir) / "images.bin").string(), i);
  write_file_atomic((fs::path(dir) / "points3D.bin").string(), p);
}

namespace {

void intrinsics_by_model(const ColmapCamera& cam, const std::string& path, double* fx, double* fy, double* cx,
                       double* cy, Distortion* d) {
  const ModelInfo* m = model_by_name(cam.model);
  if (!m) fail(path, "unknown camera model '" + cam.model + "'");
  if (static_cast<int>(cam.params.size()) != m->num_params) {
    fail(path, "camera " + std::to_string(cam.id) + " has the wrong number of parameters for " + cam.model);
  }
  const auto& q = cam.params;
  *d = Distortion{};
  const std::string& n = cam.model;
  if (n == "SIMPLE_PINHOLE" || n == "SIMPLE_RADIAL" || n == "RADIAL" || n == "SIMPLE_RADIAL_FISHEYE" ||
      n == "RADIAL_FISHEYE") {
    *fx = *fy = q[0];
    *cx = q[1];
    *cy = q[2];
    if (n == "SIMPLE_RADIAL") d->k[0] = q[3];
    if (n == "RADIAL") d->k[0] = q[3], d->k[1] = q[4];
    if (n == "SIMPLE_RADIAL_FISHEYE") d->fisheye = true, d->k[0] = q[3];
    if (n == "RADIAL_FISHEYE") d->fisheye = true, d->k[0] = q[3], d->k[1] = q[4];
    return;
  }
  if (n == "PINHOLE" || n == "OPENCV" || n == "FULL_OPENCV" || n == "OPENCV_FISHEYE") {
    *fx = q[0];
    *fy = q[1];
    *cx = q[2];
    *cy = q[3];
    if (n == "OPENCV") {
      for (int k = 0; k < 4; ++k) d->k[k] = q[4 + k];
    }
    if (n == "FULL_OPENCV") {
      // COLMAP: k1 k2 p1 p2 k3 k4 k5 k6 — the same order as OpenCV's coefficient vector.
      for (int k = 0; k < 8; ++k) d->k[k] = q[4 + k];
    }
    if (n == "OPENCV_FISHEYE") {
      d->fisheye = true;
      for (int k = 0; k < 4; ++k) d->k[k] = q[4 + k];
    }
    return;
  }
  fail(path, "unsupported camera model " + n + " (camera " + std::to_string(cam.id) +
                 "): undistort the images first, e.g. with `colmap image_undistorter`");
}

}  // namespace

// A camera that projects nothing (a focal length <= 0, an empty image) is refused here, naming the file,
// rather than by the rasterizer long after the scene was read.
void colmap_intrinsics(const ColmapCamera& cam, const std::string& path, double* fx, double* fy, double* cx,
                       double* cy, Distortion* d) {
  intrinsics_by_model(cam, path, fx, fy, cx, cy, d);
  const std::string where = "camera " + std::to_string(cam.id) + " (" + cam.model + ")";
  if (!(*fx > 0) || !(*fy > 0)) {
    fail(path, where + ": focal length must be positive (fx " + std::to_string(*fx) + ", fy " + std::to_string(*fy) + ")");
  }
  if (cam.width <= 0 || cam.height <= 0) {
    fail(path, where + ": image size must be positive (" + std::to_string(cam.width) + "x" + std::to_string(cam.height) + ")");
  }
}

Eigen::Matrix3d quaternion_to_rotation(const Eigen::Vector4d& q) {
  Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
  return quat.normalized().toRotationMatrix();
}

Eigen::Vector4d rotation_to_quaternion(const Eigen::Matrix3d& R) {
  Eigen::Quaterniond q(R);
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1;
  return {q.w(), q.x(), q.y(), q.z()};
}

}  // namespace lrf
