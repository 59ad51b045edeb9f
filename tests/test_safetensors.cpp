#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/safetensors.h"
#include "lrf/core/state_dict.h"
#include "reference_helper.h"

namespace {

std::string with_header(const std::string& json, const std::string& data) {
  std::string out(8, '\0');
  std::uint64_t n = json.size();
  for (int i = 0; i < 8; ++i) out[i] = static_cast<char>((n >> (8 * i)) & 0xff);
  return out + json + data;
}

// Expects lrf::Error whose message contains `needle` (the file name is always in it).
void expect_error(const std::string& bytes, const std::string& needle) {
  try {
    lrf::parse_safetensors(bytes, "bad.safetensors");
    ADD_FAILURE() << "no error; expected one mentioning '" << needle << "'";
  } catch (const lrf::Error& e) {
    std::string msg = e.what();
    EXPECT_NE(msg.find("bad.safetensors"), std::string::npos) << msg;
    EXPECT_NE(msg.find(needle), std::string::npos) << msg;
  }
}

}  // namespace

TEST(Safetensors, RoundTripKeepsDtypesShapesOrderAndMetadata) {
  lrf::StateDict sd;
  sd.insert("z_first", torch::randn({3, 4}));
  sd.insert("half", torch::randn({2, 5}).to(torch::kHalf));
  sd.insert("bf16", torch::randn({7}).to(torch::kBFloat16));
  sd.insert("long", torch::arange(-5, 5, torch::kLong).reshape({2, 5}));
  sd.insert("transposed", torch::randn({4, 6}).t());  // non-contiguous input is written contiguously
  sd.insert("scalar", torch::tensor(3.5f));
  auto dir = lrf_test::fresh_dir("st_roundtrip");
  std::string path = (dir / "a.safetensors").string();
  lrf::write_safetensors(path, sd, {{"format", "pt"}, {"who", "lrf"}});
  lrf::StateDict back = lrf::read_safetensors(path);
  ASSERT_EQ(back.size(), sd.size());
  for (std::size_t i = 0; i < sd.size(); ++i) {
    EXPECT_EQ(back[i].key(), sd[i].key());  // order preserved
    EXPECT_EQ(back[i].value().scalar_type(), sd[i].value().scalar_type());
    EXPECT_TRUE(torch::equal(back[i].value(), sd[i].value())) << sd[i].key();
  }
  auto meta = lrf::read_safetensors_metadata(path);
  EXPECT_EQ(meta["who"], "lrf");
  // Data starts 8-byte aligned, as other readers may memory-map it.
  std::string bytes = lrf::read_file(path);
  std::uint64_t n = 0;
  std::memcpy(&n, bytes.data(), 8);
  EXPECT_EQ((8 + n) % 8, 0u);
  std::filesystem::remove_all(dir);
}

TEST(Safetensors, ReadsPythonWrittenFile) {
  auto dir = lrf_test::cached_fixture("zipcases", "zipcases");
  ASSERT_FALSE(dir.empty());
  auto sd = lrf::load_state_dict((dir / "views_expected.safetensors").string());
  EXPECT_EQ(sd["half"].scalar_type(), torch::kHalf);
  EXPECT_EQ(sd["bfloat16"].scalar_type(), torch::kBFloat16);
  EXPECT_EQ(sd["long"][2][3].item<std::int64_t>(), 8);
}

TEST(Safetensors, RefusesTruncatedFile) {
  lrf::StateDict sd;
  sd.insert("w", torch::randn({16, 16}));
  std::string bytes = lrf::serialize_safetensors(sd);
  expect_error(bytes.substr(0, bytes.size() - 100), "outside");
  expect_error(bytes.substr(0, 5), "shorter than");
  expect_error(bytes.substr(0, 20), "truncated");  // header cut
}

TEST(Safetensors, RefusesHugeClaimBeforeAllocating) {
  // 10 GB claimed by a 100-byte file: refused by the bounds check, not by a failed allocation (which
  // would surface as std::bad_alloc / c10::Error rather than lrf::Error).
  std::string json = R"({"w":{"dtype":"F32","shape":[50000,50000],"data_offsets":[0,10000000000]}})";
  expect_error(with_header(json, std::string(100, '\0')), "outside");
  // Shape overflowing 64 bits.
  json = R"({"w":{"dtype":"F32","shape":[4294967296,4294967296,16],"data_offsets":[0,16]}})";
  expect_error(with_header(json, std::string(16, '\0')), "overflow");
}

TEST(Safetensors, RefusesInconsistentHeaders) {
  expect_error(with_header(R"({"w":{"dtype":"F32","shape":[4],"data_offsets":[0,12]}})", std::string(16, '\0')),
               "dtype and shape need");
  expect_error(with_header(R"({"w":{"dtype":"Q7","shape":[4],"data_offsets":[0,16]}})", std::string(16, '\0')),
               "unsupported dtype");
  expect_error(with_header(R"({"w":{"dtype":"F32","shape":[4],"data_offsets":[8,4]}})", std::string(16, '\0')),
               "outside");
  expect_error(with_header(R"({"a":{"dtype":"F32","shape":[4],"data_offsets":[0,16]},)"
                           R"("b":{"dtype":"F32","shape":[2],"data_offsets":[8,16]}})",
                           std::string(16, '\0')),
               "overlap");
  expect_error(with_header("{not json", ""), "JSON");
  expect_error(with_header(R"({"w":{"dtype":"F32","shape":[-4],"data_offsets":[0,16]}})", std::string(16, '\0')),
               "non-negative");
  std::string bad_len(8, '\xff');
  expect_error(bad_len + "{}", "implausible");
}
