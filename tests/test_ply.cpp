#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/splat/ply_io.h"

namespace fs = std::filesystem;
using namespace lrf::splat;

namespace {

Gaussians random_field(int64_t n, int c, int degree) {
  Gaussians g;
  g.max_sh_degree = degree;
  g.means = torch::randn({n, 3});
  g.log_scales = torch::randn({n, 3});
  g.quats = torch::randn({n, 4});
  g.opacity_logits = torch::randn({n, 1});
  g.sh = torch::randn({n, sh_coefficients(degree), c});
  g.make_leaves();
  return g;
}

std::string temp_file(const std::string& name) {
  auto dir = fs::temp_directory_path() / "lrf_test_ply";
  fs::create_directories(dir);
  return (dir / name).string();
}

}  // namespace

TEST(Ply, RoundTripForSeveralChannelCountsAndDegrees) {
  for (auto [c, d] : std::vector<std::pair<int, int>>{{3, 3}, {4, 0}, {32, 1}, {1, 2}}) {
    auto g = random_field(57, c, d);
    auto path = temp_file("rt.ply");
    write_ply(path, g);
    auto r = read_ply(path);
    EXPECT_EQ(r.max_sh_degree, d);
    EXPECT_EQ(r.channels(), c);
    auto a = g.parameters();
    auto b = r.parameters();
    for (size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(torch::equal(a[i]->detach(), b[i]->detach())) << i;
    EXPECT_TRUE(r.means.requires_grad());
  }
}

TEST(Ply, InriaChannelMajorRestOrderAndHeader) {
  auto g = random_field(2, 3, 1);
  auto path = temp_file("order.ply");
  write_ply(path, g);
  auto bytes = lrf::read_file(path);
  EXPECT_NE(bytes.find("property float f_rest_8\nproperty float opacity\n"), std::string::npos);
  EXPECT_NE(bytes.find("property float x\nproperty float y\nproperty float z\nproperty float nx\n"), std::string::npos);
  // f_rest_1 of vertex 0 is channel 0, second higher coefficient (Inria: features_rest transposed).
  auto body = bytes.substr(bytes.find("end_header\n") + 11);
  const float* v = reinterpret_cast<const float*>(body.data());
  const int f_rest_1 = 3 + 3 + 3 + 1;
  EXPECT_EQ(v[f_rest_1], g.sh.detach()[0][2][0].item<float>());
  const int f_rest_3 = 3 + 3 + 3 + 3;  // channel 1, first higher coefficient
  EXPECT_EQ(v[f_rest_3], g.sh.detach()[0][1][1].item<float>());
}

TEST(Ply, WrongPropertiesAreRejectedNamingTheFile) {
  auto path = temp_file("bad.ply");
  lrf::write_file_atomic(path,
                         "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
                         "property float y\nproperty float z\nproperty float f_dc_0\nproperty float red\n"
                         "end_header\n" + std::string(20, '\0'));
  try {
    read_ply(path);
    FAIL() << "expected lrf::Error";
  } catch (const lrf::Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nx"), std::string::npos) << e.what();
  }
}

TEST(Ply, TruncatedFileAndChannelMismatchAreRejected) {
  auto g = random_field(10, 3, 0);
  auto path = temp_file("trunc.ply");
  write_ply(path, g);
  auto bytes = lrf::read_file(path);
  lrf::write_file_atomic(path, bytes.substr(0, bytes.size() - 4));
  EXPECT_THROW(read_ply(path), lrf::Error);
  write_ply(path, g);
  EXPECT_THROW(read_ply(path, 4), lrf::Error);
  lrf::write_file_atomic(path, "not a ply");
  EXPECT_THROW(read_ply(path), lrf::Error);
}
