// The Inria-layout .ply of an RGB field opens in a tool of the 3DGS ecosystem: PlayCanvas's
// splat-transform (npm) reads it and writes every Gaussian's every property back out unchanged (as CSV),
// and converts it to its compressed .ply. Skipped, with a message, only where node is missing.
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "field_helpers.h"
#include "lrf/core/atomic_file.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

lrf::test::CommandResult shell(const std::string& command) {
  lrf::test::CommandResult r{0, ""};
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  const int status = ::pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// Property names and the float32 rows of a binary little-endian .ply whose properties are all floats.
struct PlyTable {
  std::vector<std::string> names;
  std::vector<float> values;  // rows * names.size()
  size_t rows = 0;
};

PlyTable read_float_ply(const std::string& path) {
  const std::string bytes = lrf::read_file(path);
  const size_t end = bytes.find("end_header\n");
  PlyTable t;
  std::istringstream header(bytes.substr(0, end));
  std::string line;
  while (std::getline(header, line)) {
    std::istringstream words(line);
    std::string a, b, c;
    words >> a >> b >> c;
    if (a == "element" && b == "vertex") t.rows = std::stoul(c);
    if (a == "property") {
      EXPECT_EQ(b, "float") << c;
      t.names.push_back(c);
    }
  }
  t.values.resize(t.rows * t.names.size());
  const size_t data = end + std::string("end_header\n").size();
  EXPECT_EQ(bytes.size() - data, t.values.size() * sizeof(float));
  std::memcpy(t.values.data(), bytes.data() + data, std::min(bytes.size() - data, t.values.size() * sizeof(float)));
  return t;
}

}  // namespace

TEST(SplatTransform, ReadsTheInriaPlyOfAnRgbField) {
  if (shell("command -v node").exit_code != 0)
    GTEST_SKIP() << "node is not installed, so the .ply is not checked with @playcanvas/splat-transform "
                    "(Debian: apt-get install nodejs npm; then scripts/install-npm-tools.sh)";
  const fs::path tools = fs::path(LRF_BINARY).parent_path() / "npm-tools";
  const fs::path cli = tools / "node_modules/@playcanvas/splat-transform/bin/cli.mjs";
  if (!fs::exists(cli)) {
    auto install = shell("bash '" LRF_SOURCE_DIR "/scripts/install-npm-tools.sh' '" + tools.string() + "'");
    ASSERT_EQ(install.exit_code, 0) << "installing splat-transform from the npm registry failed:\n" << install.output;
  }
  const std::string field = lrf::test::tiny_field("rgb");
  lrf::test::TempDir tmp("splat_transform");
  const std::string ply = field + "/point_cloud.ply";
  const PlyTable ours = read_float_ply(ply);
  ASSERT_GT(ours.rows, 100u);

  auto csv = shell("node '" + cli.string() + "' -w '" + ply + "' '" + tmp.str() + "/splats.csv'");
  ASSERT_EQ(csv.exit_code, 0) << csv.output;
  std::ifstream in(tmp / "splats.csv");
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  std::vector<std::string> names;
  std::istringstream header(line);
  for (std::string name; std::getline(header, name, ',');) names.push_back(name);
  EXPECT_EQ(names, ours.names) << "the same properties, in the Inria order";
  size_t row = 0, mismatches = 0;
  while (std::getline(in, line) && row < ours.rows) {
    std::istringstream cells(line);
    std::string cell;
    for (size_t k = 0; k < ours.names.size() && std::getline(cells, cell, ','); ++k) {
      // Each float32 is printed as the shortest double that reads back to it: exact equality.
      if (static_cast<float>(std::strtod(cell.c_str(), nullptr)) != ours.values[row * ours.names.size() + k]) ++mismatches;
    }
    ++row;
  }
  EXPECT_EQ(row, ours.rows);
  EXPECT_EQ(mismatches, 0u);

  auto compressed = shell("node '" + cli.string() + "' -w '" + ply + "' '" + tmp.str() + "/splats.compressed.ply'");
  ASSERT_EQ(compressed.exit_code, 0) << compressed.output;
  auto summary = shell("node '" + cli.string() + "' '" + tmp.str() + "/splats.compressed.ply' -m null");
  ASSERT_EQ(summary.exit_code, 0) << summary.output;
  EXPECT_NE(summary.output.find("Row Count:** " + std::to_string(ours.rows)), std::string::npos) << summary.output;
}
