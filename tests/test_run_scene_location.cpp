// A trained run after its scene moved: eval, render, serve and refine say where they looked and take
// --scene DIR; a project folder holding both the scene and the runs can move as a whole.
#include <filesystem>
#include <regex>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.h"
#include "lrf/core/run_info.h"
#include "lrf/scene/run_scene_location.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

using lrf::test::run_lrf;
using lrf::test::TempDir;

std::string quoted(const std::string& s) { return "'" + s + "'"; }

// DIR/project/scene (a copy of the small synthetic scene) and a run trained on it, DIR/project/runs/NAME.
std::string project_with_run(const TempDir& dir, const std::string& name, const std::string& train_args) {
  const std::string scene = dir / "project/scene";
  fs::create_directories(dir / "project/runs");
  fs::copy(lrf::test::synthetic_scene(), scene, fs::copy_options::recursive);
  const std::string run = dir / ("project/runs/" + name);
  auto r = run_lrf("--threads 2 -q train " + quoted(scene) + " " + train_args + " -o " + quoted(run));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return run;
}

// Moves the scene out of the project; returns its new place.
std::string move_scene(const TempDir& dir) {
  fs::create_directories(dir / "elsewhere");
  fs::rename(dir / "project/scene", dir / "elsewhere/scene");
  return dir / "elsewhere/scene";
}

void expect_moved_scene_error(const lrf::test::CommandResult& r, const TempDir& dir) {
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("is not at " + (dir / "project/scene")), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--scene DIR"), std::string::npos) << r.output;
}

TEST(RunSceneLocation, RecordsTheSceneAbsoluteAndRelativeToTheRun) {
  const nlohmann::json j = lrf::scene_location_record("/data/project/scenes/cup/", "/data/project/runs/rgb");
  EXPECT_EQ(j["scene"], "/data/project/scenes/cup");
  EXPECT_EQ(j["scene_relative"], "../../scenes/cup");
}

TEST(RunSceneLocation, EvalAfterTheSceneMoved) {
  TempDir tmp("run_scene_eval");
  const std::string run = project_with_run(tmp, "rgb", "--iters 2");
  const auto config = lrf::read_json_file(run + "/config.json");
  EXPECT_EQ(config["scene_relative"], "../../scene");
  const std::string moved = move_scene(tmp);
  expect_moved_scene_error(run_lrf("eval " + quoted(run)), tmp);
  auto r = run_lrf("--threads 2 eval " + quoted(run) + " --scene " + quoted(moved));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(run + "/metrics.json"));
  r = run_lrf("eval " + quoted(run) + " --scene " + quoted(tmp / "nowhere"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find(tmp / "nowhere" + ": --scene: scene folder not found"), std::string::npos) << r.output;
}

TEST(RunSceneLocation, RenderAfterTheSceneMoved) {
  TempDir tmp("run_scene_render");
  const std::string run = project_with_run(tmp, "rgb", "--iters 2");
  const std::string moved = move_scene(tmp);
  expect_moved_scene_error(run_lrf("render " + quoted(run) + " -o " + quoted(tmp / "r")), tmp);
  EXPECT_FALSE(fs::exists(tmp / "r"));
  auto r = run_lrf("--threads 2 render " + quoted(run) + " -o " + quoted(tmp / "r") + " --scene " + quoted(moved));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(tmp / "r/view_000.png")) << r.output;
}

TEST(RunSceneLocation, ServeAfterTheSceneMoved) {
  TempDir tmp("run_scene_serve");
  const std::string run = project_with_run(tmp, "rgb", "--iters 2");
  const std::string moved = move_scene(tmp);
  expect_moved_scene_error(run_lrf("serve " + quoted(run) + " --port 0"), tmp);
  lrf::test::ChildProcess server({LRF_BINARY, "--threads", "2", "serve", run, "--port", "0", "--scene", moved}, true,
                                 tmp / "serve.log");
  const std::string line = server.read_line(60);
  EXPECT_TRUE(std::regex_search(line, std::regex("http://127\\.0\\.0\\.1:\\d+/"))) << "lrf serve printed: " << line;
}

TEST(RunSceneLocation, RefineAfterTheSceneMoved) {
  TempDir tmp("run_scene_refine");
  const std::string run =
      project_with_run(tmp, "latent", "--space latent --autoencoder taef2 --iters 2 --cache-dir " + quoted(tmp / "cache"));
  const std::string moved = move_scene(tmp);
  const std::string refined = tmp / "project/runs/refined";
  const std::string refine = "--threads 2 refine " + quoted(run) + " -o " + quoted(refined) +
                             " --steps 2 --cache-dir " + quoted(tmp / "cache");
  expect_moved_scene_error(run_lrf(refine), tmp);
  EXPECT_FALSE(fs::exists(refined));
  auto r = run_lrf(refine + " --scene " + quoted(moved));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // The refined run records where the scene is now, and where it lies from the refined run's own folder.
  const auto config = lrf::read_json_file(refined + "/config.json");
  EXPECT_EQ(config["scene"], moved);
  EXPECT_EQ(config["scene_relative"], "../../../elsewhere/scene");
  r = run_lrf("--threads 2 eval " + quoted(refined));
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

// The scene and its runs in one folder, moved together: the run finds the scene where it lies from it.
TEST(RunSceneLocation, AMovedProjectKeepsWorking) {
  TempDir tmp("run_scene_project");
  const std::string run = project_with_run(tmp, "rgb", "--iters 2");
  fs::rename(tmp / "project", tmp / "project-moved");
  auto r = run_lrf("--threads 2 eval " + quoted(tmp / "project-moved/runs/rgb"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("reading it at " + (tmp / "project-moved/scene")), std::string::npos) << r.output;
}

// lrf train --resume: a project moved as a whole continues; after the scene alone moved, the run names its
// old place and continues on the scene given in its place, if it has the recorded views.
TEST(RunSceneLocation, TrainResumeAfterTheSceneMoved) {
  TempDir tmp("run_scene_train");
  project_with_run(tmp, "rgb", "--steps 4 --checkpoint-every 2");
  fs::rename(tmp / "project", tmp / "project-moved");
  const std::string run = tmp / "project-moved/runs/rgb";
  auto r = run_lrf("--threads 2 train " + quoted(run) + " --resume --steps 6");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("reading it at " + (tmp / "project-moved/scene")), std::string::npos) << r.output;

  fs::create_directories(tmp / "elsewhere");
  fs::rename(tmp / "project-moved/scene", tmp / "elsewhere/scene");
  r = run_lrf("train " + quoted(run) + " --resume --steps 8");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("lrf train SCENE -o " + run + " --resume"), std::string::npos) << r.output;
  const std::string other = lrf::test::synthetic_scene({12, "64x48", 3, 800});
  r = run_lrf("train " + quoted(other) + " -o " + quoted(run) + " --resume --steps 8");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("is it the same scene?"), std::string::npos) << r.output;
  r = run_lrf("--threads 2 train " + quoted(tmp / "elsewhere/scene") + " -o " + quoted(run) + " --resume --steps 8");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("resuming"), std::string::npos) << r.output;
  EXPECT_EQ(lrf::read_json_file(run + "/config.json")["scene"], tmp / "elsewhere/scene");
}

TEST(RunSceneLocation, AnotherSceneIsRefused) {
  TempDir tmp("run_scene_other");
  const std::string run = project_with_run(tmp, "rgb", "--iters 2");
  const std::string other = lrf::test::synthetic_scene({12, "64x48", 3, 800});
  auto r = run_lrf("eval " + quoted(run) + " --scene " + quoted(other));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("is it the same scene?"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(run + "/metrics.json"));
}

}  // namespace
