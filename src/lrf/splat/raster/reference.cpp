#include "lrf/splat/raster/reference.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace lrf::splat {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Real SH basis in 3DGS order and signs, constants written from their closed forms (not copied from the
// fast path's table) so that a typo in either shows up as a mismatch.
std::vector<double> sh_basis_reference(int degree, const Eigen::Vector3d& d) {
  const double x = d.x(), y = d.y(), z = d.z();
  std::vector<double> b;
  b.push_back(0.5 / std::sqrt(kPi));
  if (degree >= 1) {
    const double c1 = std::sqrt(3.0 / (4 * kPi));
    b.insert(b.end(), {-c1 * y, c1 * z, -c1 * x});
  }
  if (degree >= 2) {
    const double a = 0.5 * std::sqrt(15.0 / kPi), m = 0.25 * std::sqrt(5.0 / kPi), e = 0.25 * std::sqrt(15.0 / kPi);
    b.insert(b.end(), {a * x * y, -a * y * z, m * (2 * z * z - x * x - y * y), -a * x * z, e * (x * x - y * y)});
  }
  if (degree >= 3) {
    const double p = 0.25 * std::sqrt(35.0 / (2 * kPi)), q = 0.5 * std::sqrt(105.0 / kPi);
    const double r = 0.25 * std::sqrt(21.0 / (2 * kPi)), s = 0.25 * std::sqrt(7.0 / kPi);
    const double u = 0.25 * std::sqrt(105.0 / kPi);
    const double xx = x * x, yy = y * y, zz = z * z;
    b.insert(b.end(), {-p * y * (3 * xx - yy), q * x * y * z, -r * y * (4 * zz - xx - yy),
                       s * z * (2 * zz - 3 * xx - 3 * yy), -r * x * (4 * zz - xx - yy), u * z * (xx - yy),
                       -p * x * (xx - 3 * yy)});
  }
  return b;
}

struct Splat {
  bool visible = false;
  Eigen::Vector2d xy;
  Eigen::Matrix2d conic;
  double opacity = 0, depth = 0;
  int radius = 0;
  int rect[4] = {0, 0, 0, 0};
  std::vector<double> color;
};

void mix(uint64_t& h, uint64_t v) { h = (h ^ v) * 0x100000001b3ULL; }

}  // namespace

ReferenceOutput render_reference(const torch::Tensor& means_in, const torch::Tensor& log_scales_in,
                                 const torch::Tensor& quats_in, const torch::Tensor& opacity_in,
                                 const torch::Tensor& sh_in, const RasterSettings& s,
                                 const torch::Tensor& xy_offset_in) {
  auto f64 = [](const torch::Tensor& t) { return t.detach().to(torch::kFloat64).contiguous(); };
  const auto means = f64(means_in), log_scales = f64(log_scales_in), quats = f64(quats_in);
  const auto logits = f64(opacity_in), sh = f64(sh_in);
  const auto xy_offset = xy_offset_in.defined() ? f64(xy_offset_in) : torch::Tensor();
  const int64_t n = means.size(0), K = sh.size(1), C = sh.size(2);
  const int W = s.width, H = s.height, tiles_x = (W + 15) / 16, tiles_y = (H + 15) / 16;
  const Eigen::Matrix3d& Rw = s.R;
  const Eigen::Vector3d campos = -Rw.transpose() * s.t;
  std::vector<double> bg(C, 0.0);
  if (s.background.defined()) {
    const auto b = s.background.detach().to(torch::kFloat64).contiguous().reshape({-1});
    for (int64_t c = 0; c < C; ++c) bg[c] = b.data_ptr<double>()[c];
  }

  ReferenceOutput out;
  out.xy = torch::zeros({n, 2}, torch::kFloat64);
  out.radii = torch::zeros({n}, torch::kInt32);
  uint64_t hash = 0xcbf29ce484222325ULL;
  std::vector<Splat> splats(n);
  for (int64_t i = 0; i < n; ++i) {
    Splat& sp = splats[i];
    const double* m = means.data_ptr<double>() + 3 * i;
    const double* q = quats.data_ptr<double>() + 4 * i;
    const double* ls = log_scales.data_ptr<double>() + 3 * i;
    const Eigen::Vector3d mu(m[0], m[1], m[2]);
    const Eigen::Vector3d p = Rw * mu + s.t;
    Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
    if (p.z() < s.near || quat.norm() == 0) {
      mix(hash, 1);
      continue;
    }
    const Eigen::Matrix3d rot = quat.normalized().toRotationMatrix();
    const Eigen::Vector3d scale(std::exp(ls[0]), std::exp(ls[1]), std::exp(ls[2]));
    const Eigen::Matrix3d sigma = rot * scale.cwiseAbs2().asDiagonal() * rot.transpose();
    // Jacobian of the perspective map at the mean, with x/z and y/z clamped to 1.3× each side's extent.
    const double rx_raw = p.x() / p.z(), ry_raw = p.y() / p.z();
    const double rx = std::clamp(rx_raw, -1.3 * s.cx / s.fx, 1.3 * (W - s.cx) / s.fx);
    const double ry = std::clamp(ry_raw, -1.3 * s.cy / s.fy, 1.3 * (H - s.cy) / s.fy);
    mix(hash, 2 + (rx != rx_raw) + 2 * (ry != ry_raw));
    Eigen::Matrix<double, 2, 3> J;
    J << s.fx / p.z(), 0, -s.fx * rx / p.z(), 0, s.fy / p.z(), -s.fy * ry / p.z();
    const Eigen::Matrix2d cov = J * Rw * sigma * Rw.transpose() * J.transpose();
    const Eigen::Matrix2d cov_f = cov + s.dilation * Eigen::Matrix2d::Identity();
    if (!(cov_f.determinant() > 0)) {
      mix(hash, 7);
      continue;
    }
    double comp = 1;
    if (s.mip_2d_filter) {
      const double ratio = cov.determinant() / cov_f.determinant();
      comp = std::sqrt(std::max(ratio, 0.000025));
      mix(hash, ratio < 0.000025 ? 9 : 8);
    }
    sp.xy = Eigen::Vector2d(s.fx * p.x() / p.z() + s.cx, s.fy * p.y() / p.z() + s.cy);
    if (xy_offset.defined())
      sp.xy += Eigen::Vector2d(xy_offset.data_ptr<double>()[2 * i], xy_offset.data_ptr<double>()[2 * i + 1]);
    const double mid = 0.5 * cov_f.trace();
    const double lambda = mid + std::sqrt(std::max(0.1, mid * mid - cov_f.determinant()));
    sp.radius = static_cast<int>(std::ceil(3 * std::sqrt(lambda)));
    const double px = sp.xy.x() - 0.5, py = sp.xy.y() - 0.5;  // Inria's pixel coordinates
    auto tile = [](double v, int grid) { return std::min(grid, std::max(0, static_cast<int>(v / 16))); };
    sp.rect[0] = tile(px - sp.radius, tiles_x);
    sp.rect[1] = tile(py - sp.radius, tiles_y);
    sp.rect[2] = tile(px + sp.radius + 15, tiles_x);
    sp.rect[3] = tile(py + sp.radius + 15, tiles_y);
    if ((sp.rect[2] - sp.rect[0]) * (sp.rect[3] - sp.rect[1]) == 0) {
      mix(hash, 10);
      sp.radius = 0;
      continue;
    }
    sp.visible = true;
    sp.conic = cov_f.inverse();
    sp.opacity = comp / (1 + std::exp(-logits.data_ptr<double>()[i]));
    sp.depth = p.z();
    out.xy.data_ptr<double>()[2 * i] = sp.xy.x();
    out.xy.data_ptr<double>()[2 * i + 1] = sp.xy.y();
    out.radii.data_ptr<int32_t>()[i] = sp.radius;
    // Colour: SH along the view direction, + 0.5, clamped at 0.
    const auto basis = sh_basis_reference(s.sh_degree, (mu - campos).normalized());
    const double* coeffs = sh.data_ptr<double>() + i * K * C;
    sp.color.assign(C, 0.5);
    for (int64_t c = 0; c < C; ++c) {
      for (size_t k = 0; k < basis.size(); ++k) sp.color[c] += basis[k] * coeffs[k * C + c];
      mix(hash, sp.color[c] < 0 ? 11 : 12);
      sp.color[c] = std::max(sp.color[c], 0.0);
    }
  }

  std::vector<int64_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int64_t a, int64_t b) { return splats[a].depth < splats[b].depth; });

  out.image = torch::zeros({C, H, W}, torch::kFloat64);
  out.alpha = torch::zeros({1, H, W}, torch::kFloat64);
  out.depth = torch::zeros({1, H, W}, torch::kFloat64);
  double* image = out.image.data_ptr<double>();
  std::vector<double> acc(C);
  for (int i = 0; i < H; ++i)
    for (int j = 0; j < W; ++j) {
      double T = 1, acc_depth = 0;
      std::fill(acc.begin(), acc.end(), 0.0);
      const int tx = j / 16, ty = i / 16;
      for (int64_t g : order) {
        const Splat& sp = splats[g];
        if (!sp.visible) continue;
        if (tx < sp.rect[0] || tx >= sp.rect[2] || ty < sp.rect[1] || ty >= sp.rect[3]) {
          mix(hash, 20);
          continue;
        }
        const Eigen::Vector2d d = sp.xy - Eigen::Vector2d(j + 0.5, i + 0.5);
        const double power = -0.5 * d.dot(sp.conic * d);
        const double raw_alpha = sp.opacity * std::exp(power);
        const double alpha = std::min(0.99, raw_alpha);
        if (power > 0 || alpha < 1.0 / 255) {
          mix(hash, 21);
          continue;
        }
        mix(hash, raw_alpha > 0.99 ? 22 : 23);
        if (T * (1 - alpha) < 1e-4) {
          mix(hash, 24);
          break;
        }
        for (int64_t c = 0; c < C; ++c) acc[c] += sp.color[c] * alpha * T;
        acc_depth += sp.depth * alpha * T;
        T *= 1 - alpha;
      }
      for (int64_t c = 0; c < C; ++c) image[(c * H + i) * W + j] = acc[c] + T * bg[c];
      out.alpha.data_ptr<double>()[i * W + j] = 1 - T;
      out.depth.data_ptr<double>()[i * W + j] = acc_depth;
    }
  out.decisions = hash;
  return out;
}

}  // namespace lrf::splat
