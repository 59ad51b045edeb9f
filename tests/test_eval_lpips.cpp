#include <cstdio>
#include <cstdlib>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/run_info.h"
#include "lrf/eval/lpips.h"
#include "lrf/eval/npy_state_dict.h"
#include "test_helpers.h"

namespace {

const char* kPython = "/usr/bin/python3";

// Runs the PyTorch reference script into `dir`; fails the test with the script's output if it cannot.
bool run_reference(const std::string& dir) {
  std::string probe = std::string(kPython) + " -c 'import torch, numpy' 2>&1";
  if (std::system(probe.c_str()) != 0) {
    ADD_FAILURE() << kPython << " cannot import torch and numpy: install Debian's python3-torch and "
                  << "python3-numpy (scripts/install-deps.sh); the LPIPS test compares with PyTorch.";
    return false;
  }
  std::string cmd = std::string(kPython) + " " + LRF_SOURCE_DIR + "/tests/reference/lpips_reference.py '" + dir +
                    "' 0 2>&1";
  std::string output;
  FILE* p = ::popen(cmd.c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) output.append(buf, n);
  if (::pclose(p) != 0) {
    ADD_FAILURE() << "the PyTorch reference script failed:\n" << output;
    return false;
  }
  return true;
}

// A complete lpips-layout state dict with random values (shapes are all the loader checks).
lrf::TensorMap random_state_dict() {
  lrf::TensorMap sd;
  for (const auto& [key, shape] : lrf::Lpips::expected_keys()) sd[key] = torch::rand(shape) * 0.1;
  sd["scaling_layer.shift"] = torch::tensor({-0.030f, -0.088f, -0.188f}).view({1, 3, 1, 1});
  sd["scaling_layer.scale"] = torch::tensor({0.458f, 0.448f, 0.450f}).view({1, 3, 1, 1});
  return sd;
}

using lrf::test::error_of;

}  // namespace

TEST(EvalLpips, MatchesPyTorchReference) {
  lrf::test::TempDir dir("lpips_ref");
  ASSERT_TRUE(run_reference(dir.str()));
  auto weights = lrf::read_npy_state_dict(dir / "weights");
  auto img0 = lrf::npy_to_tensor(lrf::read_npy(dir / "img0.npy"));
  auto img1 = lrf::npy_to_tensor(lrf::read_npy(dir / "img1.npy"));
  auto expected = lrf::read_json_file(dir / "expected.json");

  // Both run the same float32 network; they can differ only in summation order inside the convolutions
  // (libtorch's and PyTorch's kernels may block differently), ~1e-7 relative after 13 layers.
  // 1e-5 relative leaves margin for that and catches any real difference (a wrong constant, pool, slice
  // boundary or eps moves the value by far more than 1e-3).
  auto lpips = lrf::Lpips::from_state_dict(weights, dir / "weights");
  auto layers = lpips.layer_distances(img0, img1);
  ASSERT_EQ(layers.size(), 5u);
  for (size_t k = 0; k < 5; ++k) {
    double want = expected["layers"][k].get<double>();
    EXPECT_NEAR(layers[k], want, 1e-5 * std::abs(want)) << "layer " << k;
  }
  double want = expected["distance"].get<double>();
  double got = lpips.distance(img0, img1);
  EXPECT_NEAR(got, want, 1e-5 * want);
  char relative[32];
  std::snprintf(relative, sizeof relative, "%.3g", std::abs(got - want) / want);
  RecordProperty("relative_error", relative);  // in the XML output, for the record
  EXPECT_GT(want, 1e-3);  // a real, non-degenerate distance
  EXPECT_EQ(lpips.distance(img0, img0), 0.0);

  // The torchvision layout for the backbone plus a lin-only dict gives the same network.
  lrf::TensorMap lin, backbone;
  for (const auto& [key, t] : weights) {
    if (key.rfind("net.slice", 0) == 0) {
      std::string rest = key.substr(std::string("net.sliceN.").size());  // "<index>.<param>"
      backbone["features." + rest] = t;
    } else {
      lin[key] = t;
    }
  }
  backbone["classifier.0.weight"] = torch::zeros({4, 4});  // torchvision's head is ignored
  auto split = lrf::Lpips::from_state_dicts(lin, backbone);
  EXPECT_EQ(split.distance(img0, img1), got);
}

TEST(EvalLpips, StrictLoadingListsEveryProblemInOneError) {
  auto sd = random_state_dict();
  EXPECT_NO_THROW(lrf::Lpips::from_state_dict(sd));
  sd.erase("scaling_layer.shift");  // optional: the constants are built in
  sd.erase("scaling_layer.scale");
  EXPECT_NO_THROW(lrf::Lpips::from_state_dict(sd));

  auto bad = random_state_dict();
  bad.erase("net.slice3.12.bias");
  bad["net.slice9.0.weight"] = torch::zeros({1});
  bad["lin2.model.1.weight"] = torch::zeros({1, 255, 1, 1});
  std::string what = error_of([&] { lrf::Lpips::from_state_dict(bad, "/weights/lpips.pth"); });
  EXPECT_NE(what.find("/weights/lpips.pth"), std::string::npos) << what;
  EXPECT_NE(what.find("missing keys: net.slice3.12.bias"), std::string::npos) << what;
  EXPECT_NE(what.find("unexpected keys: net.slice9.0.weight"), std::string::npos) << what;
  EXPECT_NE(what.find("lin2.model.1.weight (/weights/lpips.pth): [1, 255, 1, 1], expected [1, 256, 1, 1]"),
            std::string::npos)
      << what;

  // A layer index that is in the wrong slice is not accepted under any name.
  auto moved = random_state_dict();
  moved["net.slice2.0.weight"] = moved.at("net.slice1.0.weight");
  moved.erase("net.slice1.0.weight");
  what = error_of([&] { lrf::Lpips::from_state_dict(moved); });
  EXPECT_NE(what.find("unexpected keys: net.slice2.0.weight"), std::string::npos) << what;

  // Other scaling constants are another network.
  auto scaled = random_state_dict();
  scaled["scaling_layer.scale"] = torch::ones({1, 3, 1, 1});
  what = error_of([&] { lrf::Lpips::from_state_dict(scaled); });
  EXPECT_NE(what.find("scaling_layer.scale differs"), std::string::npos) << what;
}

TEST(EvalLpips, SplitDictsAreCheckedPerRole) {
  auto sd = random_state_dict();
  lrf::TensorMap lin, backbone;
  for (const auto& [key, t] : sd) (key.rfind("net.", 0) == 0 ? backbone : lin)[key] = t;
  EXPECT_NO_THROW(lrf::Lpips::from_state_dicts(lin, backbone));
  // torch::OrderedDict (what core's weight-file loader returns) converts with tensor_map().
  torch::OrderedDict<std::string, torch::Tensor> ordered;
  for (const auto& [key, t] : sd) ordered.insert(key, t);
  EXPECT_NO_THROW(lrf::Lpips::from_state_dict(lrf::tensor_map(ordered)));
  // Backbone keys in the lin file, or the same layer in both layouts, are reported with their files.
  auto lin_plus = lin;
  lin_plus["features.0.weight"] = sd.at("net.slice1.0.weight");
  std::string what = error_of([&] { lrf::Lpips::from_state_dicts(lin_plus, backbone, "lin.pth", "vgg.pth"); });
  EXPECT_NE(what.find("unexpected keys: features.0.weight (lin.pth)"), std::string::npos) << what;
  auto both = backbone;
  both["features.0.weight"] = sd.at("net.slice1.0.weight");
  what = error_of([&] { lrf::Lpips::from_state_dicts(lin, both, "lin.pth", "vgg.pth"); });
  EXPECT_NE(what.find("keys given twice"), std::string::npos) << what;
  // The lin file alone is not enough.
  what = error_of([&] { lrf::Lpips::from_state_dicts(lin, {}, "lin.pth", "vgg.pth"); });
  EXPECT_NE(what.find("missing keys: net.slice1.0.bias"), std::string::npos) << what;
}

TEST(EvalLpips, RejectsBadImages) {
  auto lpips = lrf::Lpips::from_state_dict(random_state_dict());
  EXPECT_THROW(lpips.distance(torch::rand({3, 32, 32}), torch::rand({3, 32, 31})), lrf::Error);
  EXPECT_THROW(lpips.distance(torch::rand({1, 32, 32}), torch::rand({1, 32, 32})), lrf::Error);
  EXPECT_THROW(lpips.distance(torch::rand({3, 8, 32}), torch::rand({3, 8, 32})), lrf::Error);
  // Non-multiples of 16 work (the pools floor, as in PyTorch).
  EXPECT_GE(lpips.distance(torch::rand({3, 23, 37}), torch::rand({3, 23, 37})), 0.0);
}

TEST(EvalLpips, NpyStateDictFolderErrorsNameThePath) {
  std::string what = error_of([] { lrf::read_npy_state_dict("/nonexistent_lrf_weights"); });
  EXPECT_NE(what.find("/nonexistent_lrf_weights"), std::string::npos) << what;
  lrf::test::TempDir dir("npy_sd_empty");
  what = error_of([&] { lrf::read_npy_state_dict(dir.str()); });
  EXPECT_NE(what.find("no .npy files"), std::string::npos) << what;
}
