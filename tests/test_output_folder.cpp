// A training run that fails before its first checkpoint leaves nothing that blocks a retry: the output
// folder it created is removed (with the parents it created), a folder that held only such a run's
// config.json is started again without --force, and no .lock is ever left behind.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/folder_lock.h"
#include "lrf/core/run_info.h"
#include "lrf/splat/run/train_run.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

using lrf::test::run_lrf;

std::string quote(const std::string& s) { return "'" + s + "'"; }

std::string train(const std::string& scene, const std::string& out, const std::string& extra = "") {
  return "--threads 2 -q train " + quote(scene) + " -o " + quote(out) + " --iters 20 --sh-degree 1 " + extra;
}

TEST(OutputFolder, FailedStartsRemoveTheFoldersTheyCreated) {
  const std::string scene = lrf::test::synthetic_scene();
  lrf::test::TempDir tmp("failed_start");
  const std::string out = tmp / "runs/a/out";
  const std::vector<std::pair<std::string, std::string>> failures = {
      {train("/nonexistent/scene", out), "scene folder not found"},                                  // scene
      {train(scene, out, "--space latent --autoencoder no-such-model"), "no-such-model"},            // model
      {train(scene, out, "--train-views 100"), "more training views than the split leaves"},          // split
      {train(scene, out, "--downscale 2"), "lrf needs at least 32 pixels per side"},                  // size
  };
  for (const auto& [args, message] : failures) {
    auto r = run_lrf(args);
    EXPECT_EQ(r.exit_code, 1) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(tmp / "runs")) << args << ": left " << out;
  }
  // A folder that existed before is kept, and holds no .lock.
  fs::create_directories(out);
  auto r = run_lrf(train("/nonexistent/scene", out));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_TRUE(fs::exists(out));
  EXPECT_FALSE(fs::exists(lrf::FolderLock::lock_file(out)));
}

// A bad image stops the run after it wrote config.json: nothing is left, and once the image is fixed a plain
// rerun works (it used to say "pass --resume or --force", and --resume "no checkpoint to resume from").
TEST(OutputFolder, RetryAfterABadImageJustWorks) {
  lrf::test::TempDir tmp("bad_image");
  const std::string scene = tmp / "scene", out = tmp / "out";
  fs::copy(lrf::test::synthetic_scene(), scene, fs::copy_options::recursive);
  const std::string image = scene + "/images/view_003.png", good = lrf::read_file(image);
  lrf::write_file_atomic(image, "not an image");
  auto r = run_lrf(train(scene, out));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("view_003.png: cannot decode image"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));

  // The same failure in a folder this run did not create leaves its config.json (as a run killed before its
  // first checkpoint does): --resume says how to start again, and a plain rerun does.
  fs::create_directories(out);
  r = run_lrf(train(scene, out));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  ASSERT_TRUE(fs::exists(out + "/config.json"));
  EXPECT_TRUE(lrf::splat::stopped_before_first_checkpoint(out));
  lrf::write_file_atomic(image, good);
  r = run_lrf(train(scene, out, "--resume"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("the run stopped before its first checkpoint: run the same command without --resume"),
            std::string::npos) << r.output;
  r = run_lrf(train(scene, out));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(lrf::read_json_file(out + "/config.json").contains("result"));
  EXPECT_FALSE(fs::exists(lrf::FolderLock::lock_file(out)));
  // A finished run is not taken over.
  r = run_lrf(train(scene, out));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("pass --resume to continue its run or --force"), std::string::npos) << r.output;
  // Nor is a folder of someone else's files.
  fs::remove_all(out);
  fs::create_directories(out);
  lrf::write_file_atomic(out + "/config.json", "{\"mine\": true}");
  EXPECT_FALSE(lrf::splat::stopped_before_first_checkpoint(out));
}

TEST(OutputFolder, ReleasedLocksLeaveNoLockFile) {
  lrf::test::TempDir tmp("lock_file_removed");
  {
    lrf::FolderLock lock(tmp.str());
    EXPECT_TRUE(fs::exists(lrf::FolderLock::lock_file(tmp.str())));
    EXPECT_NE(lrf::test::error_of([&] { lrf::FolderLock again(tmp.str()); }).find("in use by another lrf job"),
              std::string::npos);
    // The refused second holder did not remove the holder's file.
    EXPECT_TRUE(fs::exists(lrf::FolderLock::lock_file(tmp.str())));
  }
  EXPECT_FALSE(fs::exists(lrf::FolderLock::lock_file(tmp.str())));
  {
    auto file_lock = lrf::FolderLock::for_output_file(tmp / "enc.safetensors");
    EXPECT_TRUE(fs::exists(tmp / "enc.safetensors.lock"));
  }
  EXPECT_FALSE(fs::exists(tmp / "enc.safetensors.lock"));
}

}  // namespace
