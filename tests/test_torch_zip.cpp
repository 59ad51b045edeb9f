#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/pickle.h"
#include "lrf/core/state_dict.h"
#include "lrf/core/torch_zip.h"
#include "reference_helper.h"

namespace fs = std::filesystem;

namespace {

// Runs `f`, expects lrf::Error containing every needle.
template <typename F>
void expect_error(F f, std::initializer_list<std::string> needles) {
  try {
    f();
    ADD_FAILURE() << "no error";
  } catch (const lrf::Error& e) {
    std::string msg = e.what();
    for (const auto& n : needles) EXPECT_NE(msg.find(n), std::string::npos) << "'" << n << "' not in: " << msg;
  }
}

// Bytes of a string literal, embedded NULs included.
template <std::size_t N>
std::string B(const char (&s)[N]) {
  return std::string(s, N - 1);
}

lrf::pickle::Ref unpickle(const std::string& bytes) {
  return lrf::pickle::unpickle(bytes, "test.pkl", [](const lrf::pickle::Value&) -> lrf::pickle::Ref {
    throw lrf::Error("no persistent ids in this test");
  });
}

class TorchZipCases : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = lrf_test::cached_fixture("zipcases", "zipcases");
    ok_ = !dir_.empty();
  }
  void SetUp() override { ASSERT_TRUE(ok_) << "fixture generation failed (see the message above)"; }
  static std::string path(const std::string& name) { return (dir_ / name).string(); }
  static fs::path dir_;
  static bool ok_;
};
fs::path TorchZipCases::dir_;
bool TorchZipCases::ok_ = false;

}  // namespace

TEST(TorchZip, ReadsRealTaef2Checkpoint) {
  std::string path = lrf_test::shared_dir() + "/models/taef2/taef2_encoder.pth";
  lrf::StateDict sd = lrf::load_state_dict(path);
  ASSERT_EQ(sd.size(), 79u);
  EXPECT_EQ(sd[0].key(), "0.weight");  // file order kept
  EXPECT_EQ(sd["0.weight"].sizes(), (std::vector<int64_t>{64, 3, 3, 3}));
  EXPECT_EQ(sd["0.weight"].scalar_type(), torch::kHalf);
  EXPECT_EQ(sd["11.pool.1.weight"].sizes(), (std::vector<int64_t>{256}));
  EXPECT_EQ(sd["14.weight"].sizes(), (std::vector<int64_t>{32, 64, 3, 3}));
  EXPECT_TRUE(sd["14.weight"].to(torch::kFloat).isfinite().all().item<bool>());
}

TEST_F(TorchZipCases, ViewsOffsetsStridesAndDtypesMatchPyTorch) {
  lrf::StateDict got = lrf::load_state_dict(path("views.pth"));  // {"state_dict": {...}, "epoch": 3, ...}
  lrf::StateDict want = lrf::load_state_dict(path("views_expected.safetensors"));
  for (const auto& w : want) {
    ASSERT_TRUE(got.contains(w.key())) << w.key();
    EXPECT_EQ(got[w.key()].scalar_type(), w.value().scalar_type()) << w.key();
    EXPECT_TRUE(torch::equal(got[w.key()].contiguous(), w.value())) << w.key();
  }
  EXPECT_EQ(got["empty"].numel(), 0);
  EXPECT_EQ(got["empty"].size(1), 3);
  EXPECT_EQ(got.size(), want.size() + 1);  // non-tensor entries (epoch, note) skipped
}

TEST_F(TorchZipCases, TrainingCheckpointYieldsItsModelAndScalarsAloneAreNoWeights) {
  // torch.save({"model": ..., "optimizer": ..., "loss": tensor, "iterations": 7}): the model's weights,
  // not the root's scalar loss.
  lrf::StateDict got = lrf::load_state_dict(path("training.pth"));
  lrf::StateDict want = lrf::load_state_dict(path("training_expected.safetensors"));
  ASSERT_EQ(got.size(), want.size());
  for (const auto& w : want) EXPECT_TRUE(torch::equal(got[w.key()], w.value())) << w.key();
  expect_error([&] { lrf::load_state_dict(path("scalars_only.pth")); },
               {"scalars_only.pth", "no weights", "loss"});
}

TEST_F(TorchZipCases, HandBuiltArchiveWithStridedView) {
  lrf::StateDict sd = lrf::load_state_dict(path("handmade_ok.pth"));
  EXPECT_TRUE(torch::equal(sd["w"], torch::tensor({2.0f, 4.0f})));
}

TEST_F(TorchZipCases, RefusesForbiddenGlobalsNamingThem) {
  expect_error([&] { lrf::load_state_dict(path("evil_os_system.pth")); }, {"evil_os_system.pth", "os.system", "refusing"});
  expect_error([&] { lrf::load_state_dict(path("evil_eval.pth")); }, {"builtins.eval"});
  expect_error([&] { lrf::load_state_dict(path("evil_popen.pth")); }, {"subprocess.Popen"});
}

TEST_F(TorchZipCases, CompressedEntriesAreAClearError) {
  expect_error([&] { lrf::load_state_dict(path("compressed.pth")); },
               {"compressed.pth", "archive/data.pkl", "is compressed", "re-save"});
}

TEST_F(TorchZipCases, RefusesStorageLargerThanItsBytes) {
  expect_error([&] { lrf::load_state_dict(path("huge_storage.pth")); }, {"claims 1000000000 elements", "16 bytes"});
  expect_error([&] { lrf::load_state_dict(path("view_overflow.pth")); }, {"exceeds its storage"});
  expect_error([&] { lrf::load_state_dict(path("entry_past_end.pth")); },
               {"archive/data/0", "4026531840 bytes extends past the end"});
}

TEST(TorchZip, RefusesNotAZipAndTruncatedArchives) {
  auto dir = lrf_test::fresh_dir("torch_zip_bad");
  std::string text = (dir / "text.pth").string();
  lrf::write_file_atomic(text, "this is not a checkpoint at all, just text");
  expect_error([&] { lrf::load_state_dict(text); }, {"text.pth", "not a weights file"});
  expect_error([&] { lrf::read_torch_zip(text); }, {"not a zip archive"});

  std::string real = lrf::read_file(lrf_test::shared_dir() + "/models/taef2/taef2_encoder.pth");
  std::string cut = (dir / "cut.pth").string();
  lrf::write_file_atomic(cut, real.substr(0, real.size() / 2));
  expect_error([&] { lrf::load_state_dict(cut); }, {"cut.pth", "truncated"});
  std::string legacy = (dir / "legacy.pth").string();
  lrf::write_file_atomic(legacy, B("\x80\x02}q\x00."));
  expect_error([&] { lrf::load_state_dict(legacy); }, {"legacy"});
  fs::remove_all(dir);
}

TEST(Pickle, RefusesGlobalsOutsideTheAllowList) {
  // GLOBAL opcode, protocol 2: refused when the global is read, before REDUCE could call it.
  expect_error([] { unpickle(B("\x80\x02" "cos\nsystem\n" "X\x02\x00\x00\x00ls" "\x85R.")); },
               {"os.system"});
  expect_error([] { unpickle(B("\x80\x02" "cbuiltins\neval\n" "N\x85R.")); }, {"builtins.eval"});
  expect_error([] { unpickle(B("\x80\x02" "csubprocess\nPopen\n" "N\x85R.")); }, {"subprocess.Popen"});
  // STACK_GLOBAL, protocol 4.
  expect_error([] { unpickle(B("\x80\x04\x8c\x02os\x8c\x06system\x93.")); }, {"os.system"});
  // torch.load in full-pickle mode would import these too; they are not tensor rebuilders.
  expect_error([] { unpickle(B("\x80\x02" "ctorch\nload\n.")); }, {"torch.load"});
}

TEST(Pickle, RefusesUnknownOpcodesAndMalformedStreams) {
  expect_error([] { unpickle(B("\x80\x02\xff.")); }, {"unknown", "0xff"});
  expect_error([] { unpickle(B("\x80\x02" "S'x'\n.")); }, {"opcode 0x53"});  // text STRING
  expect_error([] { unpickle(B("\x80\x02X\xff\xff\xff\x7f")); }, {"truncated"});
  expect_error([] { unpickle(B("\x80\x02h\x05.")); }, {"memo"});
  expect_error([] { unpickle(B("\x80\x02s.")); }, {"underflow"});
  expect_error([] { unpickle(B("\x80\x02}")); }, {"truncated"});  // no STOP
  expect_error([] { unpickle(B("\x80\x02}}.")); }, {"not balanced"});
}

TEST(Pickle, RefusesDeepNesting) {
  // 1000 nested lists: [[[[...]]]] built as EMPTY_LIST MARK ... APPENDS.
  std::string p = B("\x80\x02");
  for (int i = 0; i < 1000; ++i) p += "](";
  p += "]";
  for (int i = 0; i < 1000; ++i) p += "e";
  p += ".";
  expect_error([&] { unpickle(p); }, {"deeper than"});
  // Self-appending a memoised list (a cycle, which would leak the value tree) is refused at once.
  std::string cycle = B("\x80\x02]q\x00");
  for (int i = 0; i < 200; ++i) cycle += B("h\x00" "a");
  expect_error([&] { unpickle(cycle + "."); }, {"holds itself"});
  // So is adding to a list already placed in another one: the way to longer cycles, and to nesting
  // deeper than the bound (each level added below an already-placed list).
  expect_error([] { unpickle(B("\x80\x02]q\x00]h\x00" "a0K\x01" "a.")); }, {"already placed"});
}

TEST(Pickle, RefusesViewsExpandedFarBeyondTheirStorage) {
  // _rebuild_tensor_v2(storage of 1 float, 0, (8192, 8192), (0, 0), False, OrderedDict()): 4 bytes that
  // would become a 256 MB tensor when copied.
  auto one_float = [](const lrf::pickle::Value&) {
    auto v = std::make_shared<lrf::pickle::Value>();
    v->kind = lrf::pickle::Value::Kind::tensor;
    v->tensor = torch::ones({1});
    return v;
  };
  auto view = [&](const std::string& size) {
    return lrf::pickle::unpickle(B("\x80\x02" "ctorch._utils\n_rebuild_tensor_v2\n" "(NQK\x00") + size +
                                     B("(K\x00K\x00t\x89" "ccollections\nOrderedDict\n)RtR."),
                                 "test.pkl", one_float);
  };
  expect_error([&] { view(B("(M\x00\x20M\x00\x20t")); }, {"expands 1 stored elements to 67108864"});
  // A modest expansion (a broadcast bias, say) stays readable.
  auto ok = view(B("(K\x04K\x03t"));
  ASSERT_EQ(ok->kind, lrf::pickle::Value::Kind::tensor);
  EXPECT_EQ(ok->tensor.sizes().vec(), (std::vector<int64_t>{4, 3}));
}

TEST(Pickle, ParsesContainersAndScalars) {
  // {"a": [1, -2, 3.5], "b": (True, None), "c": 2**40}
  std::string p = B("\x80\x02}(X\x01\x00\x00\x00" "a](K\x01J\xfe\xff\xff\xff" "G@\x0c\x00\x00\x00\x00\x00\x00" "e"
                "X\x01\x00\x00\x00" "b\x88N\x86" "X\x01\x00\x00\x00" "c\x8a\x06\x00\x00\x00\x00\x00\x01" "u.");
  auto v = unpickle(p);
  ASSERT_EQ(v->kind, lrf::pickle::Value::Kind::dict);
  ASSERT_EQ(v->entries.size(), 3u);
  const auto& list = v->entries[0].second->items;
  ASSERT_EQ(list.size(), 3u);
  EXPECT_EQ(list[0]->integer, 1);
  EXPECT_EQ(list[1]->integer, -2);
  EXPECT_DOUBLE_EQ(list[2]->floating, 3.5);
  EXPECT_TRUE(v->entries[1].second->items[0]->boolean);
  EXPECT_EQ(v->entries[2].second->integer, std::int64_t{1} << 40);
}
