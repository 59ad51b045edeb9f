// `lrf ae ...` end to end: the binary built with the tests, on a real fern view and the real TAEF2.
#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/image_io.h"
#include "lrf/core/safetensors.h"
#include "lrf/core/state_dict.h"
#include "reference_helper.h"

namespace fs = std::filesystem;

namespace {

struct Result {
  int code;
  std::string out;  // stdout + stderr
};

Result run(const std::string& args) {
  std::string cmd = std::string(LRF_BINARY) + " --threads 2 " + args + " 2>&1";
  Result r{-1, ""};
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  while (std::fgets(buf.data(), buf.size(), p)) r.out += buf.data();
  int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string fern(int i) {
  char name[64];
  std::snprintf(name, sizeof name, "/scenes/llff-fern/images_8/image%03d.png", i);
  return lrf_test::shared_dir() + name;
}

// A real fern view cut to 132x101 (not multiples of 8) and written to `dir`: small, so the CLI tests
// stay fast, and the CLI must centre-crop it to 128x96.
std::string small_fern(const fs::path& dir, int i) {
  cv::Mat image = lrf::read_image_rgb(fern(i));
  std::string path = (dir / ("fern" + std::to_string(i) + ".png")).string();
  lrf::write_image_rgb(path, image(cv::Rect(180, 140, 132, 101)).clone());
  return path;
}

std::string taef2() { return " --autoencoder " + lrf_test::shared_dir() + "/models/taef2"; }

}  // namespace

TEST(CliAe, RoundtripJsonReportsPsnrPerImage) {
  auto dir = lrf_test::fresh_dir("cli_roundtrip");
  Result r = run("--quiet ae roundtrip --json" + taef2() + " " + small_fern(dir, 0) + " " + small_fern(dir, 1));
  ASSERT_EQ(r.code, 0) << r.out;
  auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["images"].size(), 2u);
  EXPECT_EQ(j["images"][0]["width"], 128);  // 132x101 centre-cropped to multiples of 8
  EXPECT_EQ(j["images"][0]["height"], 96);
  EXPECT_EQ(j["images"][0]["original_height"], 101);
  // TAEF2 reconstructs full fern views at ~26.5 dB; a small crop of fronds is harder, but a broken
  // pipeline (wrong range, channel order, crop) lands far below 20 dB.
  EXPECT_GT(j["psnr_mean"].get<double>(), 20.0);
  EXPECT_GT(j["images"][1]["encode_seconds"].get<double>(), 0.0);
  fs::remove_all(dir);
}

TEST(CliAe, EncodeThenDecodeWritesLatentAndImage) {
  auto dir = lrf_test::fresh_dir("cli_ae");
  std::string z = (dir / "z.safetensors").string(), png = (dir / "out.png").string();
  Result e = run("ae encode " + small_fern(dir, 3) + " -o " + z + taef2());
  ASSERT_EQ(e.code, 0) << e.out;
  auto sd = lrf::read_safetensors(z);
  ASSERT_EQ(sd.size(), 1u);
  EXPECT_EQ(sd["latent"].sizes(), (std::vector<int64_t>{32, 12, 16}));
  EXPECT_EQ(sd["latent"].scalar_type(), torch::kFloat);
  EXPECT_EQ(lrf::read_safetensors_metadata(z)["lrf_crop"], "128x96 centred");
  Result d = run("ae decode " + z + " -o " + png + taef2());
  ASSERT_EQ(d.code, 0) << d.out;
  EXPECT_EQ(lrf::read_image_size(png), cv::Size(128, 96));
  // Wrong channel count for the model: a clear one-line error naming the file, exit 1.
  lrf::StateDict bad;
  bad.insert("latent", torch::zeros({4, 8, 8}));
  lrf::write_safetensors((dir / "z4.safetensors").string(), bad);
  Result w = run("ae decode " + (dir / "z4.safetensors").string() + " -o " + png + taef2());
  EXPECT_EQ(w.code, 1);
  EXPECT_NE(w.out.find("z4.safetensors: latent has 4 channels but the autoencoder expects 32"), std::string::npos)
      << w.out;
  fs::remove_all(dir);
}

TEST(CliAe, ConvertKeepsTensorsAndRefusesNonCheckpoints) {
  auto dir = lrf_test::fresh_dir("cli_convert");
  std::string in = lrf_test::shared_dir() + "/models/taef2/taef2_decoder.pth";
  std::string out = (dir / "dec.safetensors").string();
  Result c = run("ae convert " + in + " -o " + out);
  ASSERT_EQ(c.code, 0) << c.out;
  auto a = lrf::load_state_dict(in), b = lrf::read_safetensors(out);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].key(), b[i].key());
    EXPECT_TRUE(torch::equal(a[i].value(), b[i].value())) << a[i].key();
  }
  std::string text = (dir / "notes.pth").string();
  lrf::write_file_atomic(text, "not weights");
  Result bad = run("ae convert " + text + " -o " + (dir / "x.safetensors").string());
  EXPECT_EQ(bad.code, 1);
  EXPECT_NE(bad.out.find("notes.pth"), std::string::npos) << bad.out;
  EXPECT_FALSE(fs::exists(dir / "x.safetensors"));
  fs::remove_all(dir);
}

TEST(CliAe, ConvertFindsTheModelInATrainingCheckpoint) {
  // VAElight's checkpoints are torch.save({model, optimizer, loss, iterations}): the model's 56 weights,
  // not the scalar loss, and the converted file is a decoder lrf loads.
  auto dir = lrf_test::fresh_dir("cli_convert_nested");
  const std::string in = lrf_test::shared_dir() + "/models/vaelight/vaelight_decoder_12870.pt";
  const std::string out = (dir / "vaelight_decoder.safetensors").string();
  Result c = run("ae convert " + in + " -o " + out);
  ASSERT_EQ(c.code, 0) << c.out;
  auto b = lrf::read_safetensors(out);
  EXPECT_EQ(b.size(), 56u);
  ASSERT_TRUE(b.contains("c4v3.weight"));
  EXPECT_EQ(b["c4v3.weight"].sizes(), (std::vector<int64_t>{16, 16, 2, 2}));
  EXPECT_FALSE(b.contains("loss"));
  Result d = run("ae roundtrip " + fern(0) + " --autoencoder vaelight --decoder " + out);
  EXPECT_EQ(d.code, 0) << d.out;
  EXPECT_NE(d.out.find("decoder " + out), std::string::npos) << d.out;
  fs::remove_all(dir);
}
