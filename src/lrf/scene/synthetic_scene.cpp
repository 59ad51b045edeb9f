#include "lrf/scene/synthetic_scene.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <random>

#include <opencv2/core.hpp>

#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/progress.h"
#include "lrf/scene/colmap_model.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDomeRadius = 9.0;
constexpr double kGroundZ = -1.0;
const Eigen::Vector3d kBoxMin(0.9, -1.6, -1.0), kBoxMax(1.9, -0.6, 0.0);
const Eigen::Vector3d kSmallCenter(-1.3, 1.2, -0.55);
constexpr double kSmallRadius = 0.45;

enum Surface { kNone, kSphere, kSmallSphere, kBox, kGround, kDome };

struct Hit {
  double t = kInf;
  Surface surface = kNone;
  Eigen::Vector3d normal;
};

void sphere(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& c, double r, Surface s,
            bool inside, Hit* hit) {
  Eigen::Vector3d oc = o - c;
  double b = oc.dot(d), q = oc.squaredNorm() - r * r, disc = b * b - q;
  if (disc < 0) return;
  double sq = std::sqrt(disc);
  double t = inside ? -b + sq : -b - sq;
  if (t > 1e-6 && t < hit->t) {
    hit->t = t;
    hit->surface = s;
    hit->normal = (o + t * d - c).normalized() * (inside ? -1.0 : 1.0);
  }
}

void box(const Eigen::Vector3d& o, const Eigen::Vector3d& d, Hit* hit) {
  double t0 = -kInf, t1 = kInf;
  int axis = 0;
  for (int a = 0; a < 3; ++a) {
    double inv = 1.0 / d[a];
    double ta = (kBoxMin[a] - o[a]) * inv, tb = (kBoxMax[a] - o[a]) * inv;
    if (ta > tb) std::swap(ta, tb);
    if (ta > t0) t0 = ta, axis = a;
    t1 = std::min(t1, tb);
  }
  if (t0 <= t1 && t0 > 1e-6 && t0 < hit->t) {
    hit->t = t0;
    hit->surface = kBox;
    hit->normal = Eigen::Vector3d::Zero();
    hit->normal[axis] = d[axis] > 0 ? -1 : 1;
  }
}

Hit intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  Hit hit;
  sphere(o, d, Eigen::Vector3d::Zero(), 1.0, kSphere, false, &hit);
  sphere(o, d, kSmallCenter, kSmallRadius, kSmallSphere, false, &hit);
  box(o, d, &hit);
  if (std::abs(d.z()) > 1e-12) {
    double t = (kGroundZ - o.z()) / d.z();
    Eigen::Vector3d p = o + t * d;
    if (t > 1e-6 && t < hit.t && p.head<2>().norm() < 6.0) {
      hit.t = t;
      hit.surface = kGround;
      hit.normal = Eigen::Vector3d(0, 0, 1);
    }
  }
  sphere(o, d, Eigen::Vector3d::Zero(), kDomeRadius, kDome, true, &hit);
  return hit;
}

// Smooth, band-limited textures: enough detail to make reconstruction non-trivial, no aliasing at the
// default resolution once supersampled.
Eigen::Vector3d albedo(Surface s, const Eigen::Vector3d& p, unsigned seed) {
  double ph = 0.37 * (seed % 97);
  switch (s) {
    case kSphere: {
      double lon = std::atan2(p.y(), p.x()), lat = std::asin(std::clamp(p.z(), -1.0, 1.0));
      double stripes = 0.5 + 0.5 * std::sin(6 * lon + ph);
      double bands = 0.5 + 0.5 * std::sin(9 * lat + 2 * std::sin(3 * lon));
      return {0.85 * stripes + 0.1, 0.25 + 0.6 * bands, 0.9 - 0.6 * stripes * bands};
    }
    case kSmallSphere: {
      double v = 0.5 + 0.5 * std::sin(10 * p.z() + 4 * std::atan2(p.y() - kSmallCenter.y(), p.x() - kSmallCenter.x()) + ph);
      return {0.95, 0.75 * v + 0.15, 0.1};
    }
    case kBox: {
      Eigen::Vector3d q = (p - kBoxMin) * 4.0;
      int checker = (int(std::floor(q.x())) + int(std::floor(q.y())) + int(std::floor(q.z()))) & 1;
      double ring = 0.5 + 0.5 * std::cos(12 * (p - 0.5 * (kBoxMin + kBoxMax)).norm() + ph);
      return checker ? Eigen::Vector3d(0.15, 0.35 + 0.4 * ring, 0.8) : Eigen::Vector3d(0.9, 0.9, 0.85 * ring + 0.1);
    }
    case kGround: {
      int checker = (int(std::floor(p.x() * 1.5)) + int(std::floor(p.y() * 1.5))) & 1;
      double wave = 0.5 + 0.5 * std::sin(3 * p.x() + 2 * p.y() + ph);
      return checker ? Eigen::Vector3d(0.55, 0.45 + 0.2 * wave, 0.3) : Eigen::Vector3d(0.25, 0.2, 0.15 + 0.2 * wave);
    }
    case kDome: {
      Eigen::Vector3d n = p.normalized();
      double az = std::atan2(n.y(), n.x());
      double v = 0.5 + 0.5 * std::sin(5 * az + 3 * n.z() + ph);
      double sky = std::clamp(0.5 + 0.5 * n.z(), 0.0, 1.0);
      return {0.35 + 0.3 * v * (1 - sky), 0.5 + 0.25 * sky, 0.6 + 0.35 * sky - 0.2 * v};
    }
    default:
      return Eigen::Vector3d::Zero();
  }
}

Eigen::Vector3d shade(const Hit& h, const Eigen::Vector3d& p, unsigned seed) {
  Eigen::Vector3d a = albedo(h.surface, p, seed);
  if (h.surface == kDome) return a;  // emissive backdrop
  const Eigen::Vector3d light = Eigen::Vector3d(0.4, 0.3, 0.85).normalized();
  double lambert = std::max(0.0, h.normal.dot(light));
  return (a * (0.4 + 0.6 * lambert)).cwiseMin(1.0);
}

int parse_size(const std::string& s, int* w, int* h) {
  return std::sscanf(s.c_str(), "%dx%d", w, h) == 2 && *w >= 8 && *h >= 8 && *w <= 8192 && *h <= 8192;
}

Eigen::Vector3d sample_surface(std::mt19937& rng, Surface* s) {
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, 1);
  double r = u(rng);
  if (r < 0.35) {
    *s = kSphere;
    return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  }
  if (r < 0.45) {
    *s = kSmallSphere;
    return kSmallCenter + kSmallRadius * Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  }
  if (r < 0.6) {
    *s = kBox;
    Eigen::Vector3d p = kBoxMin + (kBoxMax - kBoxMin).cwiseProduct(Eigen::Vector3d(u(rng), u(rng), u(rng)));
    int axis = int(u(rng) * 3) % 3;
    p[axis] = u(rng) < 0.5 ? kBoxMin[axis] : kBoxMax[axis];
    return p;
  }
  if (r < 0.85) {
    *s = kGround;
    double rad = 6.0 * std::sqrt(u(rng)), ang = 2 * M_PI * u(rng);
    return {rad * std::cos(ang), rad * std::sin(ang), kGroundZ};
  }
  *s = kDome;
  Eigen::Vector3d n(g(rng), g(rng), std::abs(g(rng)));
  return kDomeRadius * n.normalized();
}

Eigen::Vector3d surface_normal(Surface s, const Eigen::Vector3d& p) {
  switch (s) {
    case kSphere:
      return p.normalized();
    case kSmallSphere:
      return (p - kSmallCenter).normalized();
    case kBox: {
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      for (int a = 0; a < 3; ++a) {
        if (std::abs(p[a] - kBoxMin[a]) < 1e-12) n[a] = -1;
        if (std::abs(p[a] - kBoxMax[a]) < 1e-12) n[a] = 1;
      }
      return n.normalized();
    }
    case kDome:
      return -p.normalized();
    default:
      return Eigen::Vector3d(0, 0, 1);
  }
}

}  // namespace

Eigen::Vector3d synthetic_trace(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, unsigned seed,
                                double* distance) {
  Hit h = intersect(origin, dir);
  if (distance) *distance = h.t;
  if (h.surface == kNone) return Eigen::Vector3d::Zero();
  return shade(h, origin + h.t * dir, seed);
}

std::vector<Camera> synthetic_cameras(const SyntheticOptions& o) {
  int W, H;
  if (!parse_size(o.size, &W, &H)) fail_usage("--size must be WxH with 8 <= W, H <= 8192, got '" + o.size + "'");
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const double f = 0.8 * W;
  std::vector<Camera> cameras;
  for (int i = 0; i < o.views; ++i) {
    double az = 2 * M_PI * i / o.views + 0.05 * u(rng);
    double radius = 4.2 + 0.3 * u(rng);
    double height = 1.2 + 0.8 * std::sin(3.0 * az) + 0.1 * u(rng);
    Eigen::Vector3d center(radius * std::cos(az), radius * std::sin(az), height);
    Eigen::Vector3d target(0.2 * u(rng), 0.2 * u(rng), -0.3);
    Eigen::Vector3d fwd = (target - center).normalized();
    Eigen::Vector3d right = fwd.cross(Eigen::Vector3d(0, 0, 1)).normalized();
    Eigen::Vector3d down = fwd.cross(right);
    Eigen::Matrix3d R_c2w;
    R_c2w << right, down, fwd;
    Camera c;
    c.width = W;
    c.height = H;
    c.fx = c.fy = f;
    c.cx = W / 2.0;
    c.cy = H / 2.0;
    c.R = R_c2w.transpose();
    c.t = -c.R * center;
    cameras.push_back(c);
  }

  return cameras;
}

void write_synthetic_scene(const std::string& dir, const SyntheticOptions& o) {
  int W, H;
  if (!parse_size(o.size, &W, &H)) fail_usage("--size must be WxH with 8 <= W, H <= 8192, got '" + o.size + "'");
  if (o.views < 2 || o.views > 1000) fail_usage("--views must be in [2, 1000]");
  if (o.points < 0 || o.points > 1000000) fail_usage("--points must be in [0, 1000000]");
  if (fs::exists(dir) && !fs::is_empty(dir)) fail(dir, "output folder exists and is not empty");
  fs::create_directories(fs::path(dir) / "images");
  fs::create_directories(fs::path(dir) / "sparse" / "0");

  std::mt19937 rng(o.seed + 1);
  ColmapModel model;
  ColmapCamera cam;
  cam.id = 1;
  cam.model = "PINHOLE";
  cam.width = W;
  cam.height = H;
  double f = 0.8 * W;
  cam.params = {f, f, W / 2.0, H / 2.0};
  model.cameras[1] = cam;

  std::vector<Camera> cameras = synthetic_cameras(o);

  // Points first so that each view's observations can be written with its image.
  std::vector<Eigen::Vector3d> pts;
  for (int k = 0; k < o.points; ++k) {
    Surface s;
    Eigen::Vector3d p = sample_surface(rng, &s);
    Hit h;
    h.surface = s;
    h.normal = surface_normal(s, p);
    ColmapPoint cp;
    cp.id = k + 1;
    cp.xyz = p;
    cp.rgb = shade(h, p, o.seed).cast<float>();
    model.points.push_back(cp);
    pts.push_back(p);
  }

  Progress progress("synth", o.views, 2.0);
  for (int i = 0; i < o.views; ++i) {
    const Camera& c = cameras[i];
    Eigen::Matrix3d R_c2w = c.R.transpose();
    Eigen::Vector3d origin = c.center();
    cv::Mat img(H, W, CV_32FC3);
#pragma omp parallel for schedule(dynamic, 4)
    for (int y = 0; y < H; ++y) {
      for (int x = 0; x < W; ++x) {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (int sy = 0; sy < 2; ++sy) {
          for (int sx = 0; sx < 2; ++sx) {
            double px = x + 0.25 + 0.5 * sx, py = y + 0.25 + 0.5 * sy;
            Eigen::Vector3d d = R_c2w * Eigen::Vector3d((px - c.cx) / c.fx, (py - c.cy) / c.fy, 1.0);
            sum += synthetic_trace(origin, d.normalized(), o.seed);
          }
        }
        Eigen::Vector3d v = sum / 4.0;
        img.at<cv::Vec3f>(y, x) = cv::Vec3f(float(v.x()), float(v.y()), float(v.z()));
      }
    }
    char name[32];
    std::snprintf(name, sizeof name, "view_%03d.png", i);
    write_image_rgb((fs::path(dir) / "images" / name).string(), img);

    ColmapImage im;
    im.id = i + 1;
    im.camera_id = 1;
    im.name = name;
    im.qvec = rotation_to_quaternion(c.R);
    im.tvec = c.t;
    for (size_t k = 0; k < pts.size(); ++k) {
      Eigen::Vector2d px;
      double depth;
      if (!c.project(pts[k], &px, &depth)) continue;
      if (px.x() < 0 || px.y() < 0 || px.x() >= W || px.y() >= H) continue;
      Eigen::Vector3d d = pts[k] - origin;
      double dist = d.norm(), hit_t;
      synthetic_trace(origin, d / dist, o.seed, &hit_t);
      if (std::abs(hit_t - dist) > 1e-6 * dist + 1e-9) continue;  // occluded
      im.xys.push_back(px);
      im.point3d_ids.push_back(static_cast<int64_t>(k + 1));
    }
    model.images.push_back(im);
    progress.update(i + 1);
  }
  write_colmap_text((fs::path(dir) / "sparse" / "0").string(), model);
}

}  // namespace lrf
