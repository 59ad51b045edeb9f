// Camera paths (LLFF spiral, orbit, interpolation through the views) on camera rigs whose answers are
// known, against the formulas written out here in plain float64.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "lrf/camera_path/camera_path.h"
#include "lrf/camera_path/interp_path.h"
#include "lrf/camera_path/orbit_path.h"
#include "lrf/camera_path/spiral_path.h"
#include "lrf/camera_path/pose_math.h"
#include "lrf/scene/scene.h"
#include "test_helpers.h"

namespace cp = lrf::camera_path;
using Eigen::Vector3d;

namespace {

lrf::Camera intrinsics() {
  lrf::Camera c;
  c.width = 80;
  c.height = 60;
  c.fx = c.fy = 70;
  c.cx = 40;
  c.cy = 30;
  return c;
}

// Rotations from lookat are built from unit vectors; 1e-9 leaves room for a few roundings of them.
constexpr double kTol = 1e-9;

void expect_rotation(const Eigen::Matrix3d& R) {
  EXPECT_LT((R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), kTol);
  EXPECT_NEAR(R.determinant(), 1.0, kTol);
}

// The camera sees `p` at its principal point.
void expect_looks_at(const lrf::Camera& c, const Vector3d& p) {
  Eigen::Vector2d px;
  ASSERT_TRUE(c.project(p, &px));
  EXPECT_NEAR(px.x(), c.cx, 1e-6);
  EXPECT_NEAR(px.y(), c.cy, 1e-6);
}

// A forward-facing rig: a 3x3 grid of cameras in the plane z = 0 (spacing 0.4), looking along +z with
// y down (so world up is -y), and points at depths 4..10.
std::vector<lrf::Camera> forward_rig() {
  std::vector<lrf::Camera> cams;
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j) {
      lrf::Camera c = intrinsics();
      c.R.setIdentity();
      c.t = -Vector3d(0.4 * i, 0.3 * j, 0.05 * (i + j));
      cams.push_back(c);
    }
  return cams;
}

std::vector<Vector3d> forward_points() {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> xy(-2, 2), z(4, 10);
  std::vector<Vector3d> pts;
  for (int k = 0; k < 500; ++k) pts.emplace_back(xy(rng), xy(rng), z(rng));
  return pts;
}

// Object rig: 12 cameras on a circle of radius 3 at height 1 above (1, 2, 3), world up +z, looking at it.
const Vector3d kObject(1, 2, 3);
std::vector<lrf::Camera> object_rig() {
  std::vector<lrf::Camera> cams;
  for (int k = 0; k < 12; ++k) {
    const double a = 2 * M_PI * k / 12 + 0.3;
    const Vector3d eye = kObject + Vector3d(3 * std::cos(a), 3 * std::sin(a), 1.0);
    cams.push_back(cp::look_at(intrinsics(), eye, kObject, Vector3d::UnitZ()));
  }
  return cams;
}

}  // namespace

TEST(CameraPath, LookAtConvention) {
  const Vector3d eye(1, -2, 0.5), target(3, 1, 2);
  const auto c = cp::look_at(intrinsics(), eye, target, Vector3d::UnitZ());
  expect_rotation(c.R);
  EXPECT_LT((c.center() - eye).norm(), kTol);
  expect_looks_at(c, target);
  // World up appears up in the image (smaller y), and the camera's right is horizontal.
  Eigen::Vector2d above;
  ASSERT_TRUE(c.project(target + 0.1 * Vector3d::UnitZ(), &above));
  EXPECT_LT(above.y(), c.cy);
  EXPECT_NEAR(cp::camera_right(c).z(), 0.0, kTol);
  // OpenCV's own frame: looking down +z with up -y gives the identity rotation.
  const auto id = cp::look_at(intrinsics(), Vector3d::Zero(), Vector3d::UnitZ(), -Vector3d::UnitY());
  EXPECT_LT((id.R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), kTol);
  EXPECT_THROW(cp::look_at(intrinsics(), eye, eye, Vector3d::UnitZ()), lrf::Error);
  EXPECT_THROW(cp::look_at(intrinsics(), Vector3d::Zero(), Vector3d::UnitZ(), Vector3d::UnitZ()), lrf::Error);
}

TEST(CameraPath, MeanPoseAndAxes) {
  const auto rig = forward_rig();
  const auto mean = cp::mean_pose(rig);
  EXPECT_LT((mean.center - Vector3d(0, 0, 0)).norm(), kTol);
  EXPECT_LT((mean.forward - Vector3d::UnitZ()).norm(), kTol);
  EXPECT_LT((mean.down - Vector3d::UnitY()).norm(), kTol);
  Vector3d p;
  EXPECT_FALSE(cp::axes_convergence_point(rig, &p)) << "parallel axes meet nowhere";
  ASSERT_TRUE(cp::axes_convergence_point(object_rig(), &p));
  EXPECT_LT((p - kObject).norm(), 1e-9);
  EXPECT_DOUBLE_EQ(cp::quantile({4, 1, 3, 2}, 0.5), 2.5);
  EXPECT_DOUBLE_EQ(cp::quantile({4, 1, 3, 2}, 1.0), 4.0);
  EXPECT_DOUBLE_EQ(cp::quantile({4, 1, 3, 2}, 1.0 / 3), 2.0);
}

TEST(CameraPath, SpiralMatchesLlffFormula) {
  const auto rig = forward_rig();
  const auto pts = forward_points();
  cp::PathOptions o;
  o.frames = 40;
  cp::PathGeometry g;
  const auto path = cp::spiral_path(rig, pts, o, &g);
  ASSERT_EQ(path.size(), 40u);
  // The focus depth written out: near = 0.9 x the 1% depth quantile, far = 5 x the 99% one, blended by 0.75
  // in inverse depth. The rig's mean camera sits at the origin looking along +z, so depth = z.
  std::vector<double> z;
  for (const auto& p : pts) z.push_back(p.z());
  const double near = 0.9 * cp::quantile(z, 0.01), far = 5.0 * cp::quantile(z, 0.99);
  const double focus = 1.0 / (0.25 / near + 0.75 / far);
  EXPECT_LT((g.target - Vector3d(0, 0, focus)).norm(), 1e-9);
  // Radii: the 90% quantiles of the cameras' |offsets| along right, down, forward.
  std::vector<double> dx, dy, dz;
  for (const auto& c : rig) {
    dx.push_back(std::abs(c.center().x()));
    dy.push_back(std::abs(c.center().y()));
    dz.push_back(std::abs(c.center().z()));
  }
  const Vector3d radii(cp::quantile(dx, 0.9), cp::quantile(dy, 0.9), cp::quantile(dz, 0.9));
  EXPECT_LT((g.radii - radii).norm(), 1e-12);
  for (int k = 0; k < 40; ++k) {
    const auto& c = path[static_cast<size_t>(k)];
    const double th = 4 * M_PI * k / 40;  // two turns
    const Vector3d eye(radii.x() * std::cos(th), radii.y() * std::sin(th), radii.z() * std::sin(0.5 * th));
    EXPECT_LT((c.center() - eye).norm(), 1e-9) << k;
    expect_rotation(c.R);
    expect_looks_at(c, g.target);
    EXPECT_GT(cp::camera_down(c).dot(Vector3d::UnitY()), 0.9) << k;
    EXPECT_EQ(c.width, 80);
  }
  // The loop closes: two turns and one z oscillation end where they began.
  const double step = (path[1].center() - path[0].center()).norm();
  EXPECT_NEAR((path.back().center() - path.front().center()).norm(), step, 0.5 * step);
}

TEST(CameraPath, SpiralWithoutPointsUsesFallbacks) {
  const auto rig = forward_rig();
  cp::PathOptions o;
  o.frames = 5;
  cp::PathGeometry g;
  auto path = cp::spiral_path(rig, {}, o, &g);
  EXPECT_EQ(path.size(), 5u);
  // Parallel axes and no points: 10x the cameras' spread ahead.
  double spread = 0;
  for (const auto& c : rig) spread = std::max(spread, c.center().norm());
  EXPECT_NEAR(g.target.z(), 10 * spread, 1e-9);
  EXPECT_NE(g.source.find("spread"), std::string::npos) << g.source;
}

TEST(CameraPath, OrbitCirclesTheObject) {
  const auto rig = object_rig();
  std::vector<Vector3d> pts;
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 0.2);
  for (int k = 0; k < 301; ++k) pts.push_back(kObject + Vector3d(n(rng), n(rng), n(rng)));
  cp::PathOptions o;
  o.frames = 24;
  cp::PathGeometry g;
  const auto path = cp::orbit_path(rig, pts, o, &g);
  ASSERT_EQ(path.size(), 24u);
  EXPECT_NE(g.source.find("SfM"), std::string::npos);
  // The median of a cloud around kObject: within its spread's sampling error (0.2 / sqrt(301) ~ 0.012; 5 sigma).
  EXPECT_LT((g.center - kObject).norm(), 0.06);
  EXPECT_LT((g.up - Vector3d::UnitZ()).norm(), 1e-9);
  for (size_t k = 0; k < path.size(); ++k) {
    const auto& c = path[k];
    expect_rotation(c.R);
    expect_looks_at(c, g.center);
    const Vector3d d = c.center() - g.center;
    EXPECT_NEAR(d.z(), g.radii.z(), 1e-9);
    EXPECT_NEAR(std::hypot(d.x(), d.y()), g.radii.x(), 1e-9);
    if (k > 0) {
      const Vector3d p = path[k - 1].center() - g.center;
      const double turn = std::atan2(p.x() * d.y() - p.y() * d.x(), p.x() * d.x() + p.y() * d.y());
      EXPECT_NEAR(turn, 2 * M_PI / 24, 1e-9) << k;
    }
  }
  // Height and radius are the rig's (1 and 3) up to the centre's offset; the first frame faces the first camera's bearing.
  EXPECT_NEAR(g.radii.z(), 1.0, 0.06);
  EXPECT_NEAR(g.radii.x(), 3.0, 0.06);
  const Vector3d a = path[0].center() - g.center, b = rig[0].center() - g.center;
  EXPECT_NEAR(std::atan2(a.y(), a.x()), std::atan2(b.y(), b.x()), 1e-9);
  // Without points, the centre is where the cameras' axes meet: exactly the object.
  const auto again = cp::orbit_path(rig, {}, o, &g);
  EXPECT_LT((g.center - kObject).norm(), 1e-9);
  EXPECT_NEAR(g.radii.x(), 3.0, 1e-9);
  EXPECT_NEAR(g.radii.z(), 1.0, 1e-9);
}

// Photos taken with the camera on its side (each rolled 90 degrees about its axis): their up directions lie
// in the ring (and cancel out over a full turn), so the orbit's axis is the normal of the plane of the
// camera centres, pointing to the cameras' side of the object, and the orbit keeps the rig's height.
TEST(CameraPath, OrbitOfSidewaysPhotosTurnsAboutTheRingsNormal) {
  for (const int turn_degrees : {360, 180}) {  // a full ring (ups cancel) and half of one (ups lean sideways)
    std::vector<lrf::Camera> rig;
    for (int k = 0; k < 12; ++k) {
      const double t = turn_degrees * M_PI / 180.0 * k / 12.0;
      const Vector3d eye = kObject + Vector3d(3 * std::cos(t), 3 * std::sin(t), 1);
      const Vector3d tangent(-std::sin(t), std::cos(t), 0);
      rig.push_back(cp::look_at(intrinsics(), eye, kObject, tangent));
      ASSERT_LT(std::abs(cp::camera_down(rig.back()).z()), 1e-9);  // on its side: "down" is horizontal
    }
    cp::PathOptions o;
    o.frames = 8;
    cp::PathGeometry g;
    const auto path = cp::orbit_path(rig, {}, o, &g);
    SCOPED_TRACE(turn_degrees);
    EXPECT_LT((g.up - Vector3d::UnitZ()).norm(), 1e-9);
    EXPECT_LT((g.center - kObject).norm(), 1e-9);
    EXPECT_NEAR(g.radii.z(), 1.0, 1e-9);
    EXPECT_NEAR(g.radii.x(), 3.0, 1e-9);
    for (const auto& c : path) {
      expect_looks_at(c, kObject);
      EXPECT_NEAR(c.center().z(), kObject.z() + 1.0, 1e-9);
    }
  }
}

TEST(CameraPath, InterpPassesThroughTheViews) {
  const auto rig = object_rig();
  std::vector<lrf::Camera> views(rig.begin(), rig.begin() + 4);
  views[2].fx = 90;  // intrinsics are interpolated too
  cp::PathOptions o;
  o.frames = 3 * 4 + 1;  // four frames per gap: frames 0, 4, 8, 12 are the views
  const auto path = cp::interp_path(views, o);
  ASSERT_EQ(path.size(), 13u);
  for (int i = 0; i < 4; ++i) {
    const auto& c = path[static_cast<size_t>(4 * i)];
    EXPECT_LT((c.R - views[static_cast<size_t>(i)].R).cwiseAbs().maxCoeff(), 1e-12) << i;
    EXPECT_LT((c.center() - views[static_cast<size_t>(i)].center()).norm(), 1e-12) << i;
    EXPECT_DOUBLE_EQ(c.fx, views[static_cast<size_t>(i)].fx);
  }
  for (const auto& c : path) expect_rotation(c.R);
  // Halfway between views 0 and 1: the rotation halfway (slerp), the centre on the Catmull-Rom spline
  // 0.5 (-P0 + 9 P1 + 9 P2 - P3) / 8 with P0 reflected (2 P1 - P2).
  const auto& mid = path[2];
  const Eigen::Quaterniond q0(views[0].R), q1(views[1].R), qm(mid.R);
  EXPECT_NEAR(q0.angularDistance(qm), q1.angularDistance(qm), 1e-9);
  EXPECT_NEAR(q0.angularDistance(qm), 0.5 * q0.angularDistance(q1), 1e-9);
  const Vector3d P1 = views[0].center(), P2 = views[1].center(), P3 = views[2].center(), P0 = 2 * P1 - P2;
  EXPECT_LT((mid.center() - (-P0 + 9 * P1 + 9 * P2 - P3) / 16.0).norm(), 1e-12);
  EXPECT_NEAR(path[6].fx, 80.0, 1e-12) << "halfway from fx 70 to 90";
  // One view: every frame is that view.
  const auto single = cp::interp_path({views[1]}, o);
  for (const auto& c : single) EXPECT_LT((c.center() - views[1].center()).norm(), 1e-15);
}

TEST(CameraPath, SceneAndOptions) {
  const auto scene = lrf::load_scene(lrf::test::synthetic_scene({8, "64x48", 3, 800}));
  for (const char* kind : {"spiral", "orbit", "interp"}) {
    cp::PathOptions o;
    o.frames = 7;
    const auto path = cp::make_path(scene, cp::parse_path_kind(kind), o);
    ASSERT_EQ(path.size(), 7u) << kind;
    for (const auto& c : path) {
      EXPECT_TRUE(c.R.allFinite() && c.t.allFinite()) << kind;
      EXPECT_EQ(c.width, scene.views[0].camera.width);
    }
  }
  EXPECT_NE(lrf::test::error_of([] { cp::parse_path_kind("helix"); }).find("spiral, orbit or interp"), std::string::npos);
  cp::PathOptions none;
  none.frames = 0;
  EXPECT_NE(lrf::test::error_of([&] { cp::make_path(scene, cp::PathKind::spiral, none); }).find("--frames"), std::string::npos);
}
