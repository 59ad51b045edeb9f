// lrf never writes over what it reads: an output that names one of the command's inputs (the same file
// or folder, however it is spelled), the scene's folder or the folder its images come from is refused
// before any work, as a command-line error, and the input stays byte for byte as it was.
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "field_helpers.h"
#include "lrf/core/safetensors.h"
#include "lrf/core/state_dict.h"
#include "test_helpers.h"

namespace {

namespace fs = std::filesystem;
using lrf::test::run_lrf;
using lrf::test::TempDir;

std::string quoted(const std::string& path) { return "'" + path + "'"; }

// Every file under `root` (or `root` itself, a file) with its bytes.
std::map<std::string, std::string> contents(const fs::path& root) {
  std::map<std::string, std::string> files;
  auto read = [&](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream bytes;
    bytes << in.rdbuf();
    files[fs::relative(p, fs::is_directory(root) ? root : root.parent_path()).string()] = bytes.str();
  };
  if (!fs::is_directory(root)) {
    read(root);
    return files;
  }
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (e.is_regular_file()) read(e.path());
  }
  return files;
}

void copy_folder(const std::string& from, const std::string& to) {
  fs::copy(from, to, fs::copy_options::recursive);
}

// A command-line error (exit 2) that says the output is something lrf only reads.
void expect_refused(const std::string& args) {
  const auto r = run_lrf("-q " + args);
  EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
  EXPECT_NE(r.output.find("which lrf only reads"), std::string::npos) << args << "\n" << r.output;
}

std::string taef2() { return lrf::test::shared_dir() + "/models/taef2"; }

TEST(OutputsOverInputs, AutoencoderCommandsRefuseToWriteOverTheirInput) {
  TempDir tmp("outputs_ae");
  const std::string images = tmp / "images";
  fs::create_directories(images);
  const std::string image = images + "/view_001.png";
  fs::copy_file(lrf::test::synthetic_scene() + "/images/view_001.png", image);
  lrf::StateDict latent;
  latent.insert("latent", torch::zeros({32, 6, 8}));
  const std::string latent_file = tmp / "latent.safetensors";
  lrf::write_safetensors(latent_file, latent, {});
  const auto before = contents(tmp.str());

  // The round trip's decode of view_001.png is view_001.png in the output folder: here, the image itself.
  expect_refused("ae roundtrip --autoencoder " + taef2() + " " + quoted(image) + " -o " + quoted(images));
  expect_refused("ae roundtrip --autoencoder " + taef2() + " " + quoted(image) + " -o " + quoted(images + "/../images/."));
  expect_refused("ae encode --autoencoder " + taef2() + " " + quoted(image) + " -o " + quoted(image));
  expect_refused("ae decode --autoencoder " + taef2() + " " + quoted(latent_file) + " -o " +
                 quoted(tmp / "./latent.safetensors"));
  expect_refused("ae convert " + quoted(latent_file) + " -o " + quoted(latent_file));
  EXPECT_EQ(contents(tmp.str()), before) << "the inputs are unchanged";

  // Two images of one name would decode to one file: refused before either is written.
  fs::create_directories(tmp / "other");
  fs::create_directories(tmp / "decoded");
  fs::copy_file(image, tmp / "other/view_001.png");
  const auto twice = run_lrf("-q ae roundtrip --autoencoder " + taef2() + " " + quoted(image) + " " +
                             quoted(tmp / "other/view_001.png") + " -o " + quoted(tmp / "decoded"));
  EXPECT_EQ(twice.exit_code, 2) << twice.output;
  EXPECT_NE(twice.output.find("both be decoded"), std::string::npos) << twice.output;
  EXPECT_FALSE(fs::exists(tmp / "decoded/view_001.png"));

  // Elsewhere they run.
  const auto ok = run_lrf("-q ae roundtrip --autoencoder " + taef2() + " " + quoted(image) + " -o " +
                          quoted(tmp / "decoded"));
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_TRUE(fs::exists(tmp / "decoded/view_001.png"));
}

TEST(OutputsOverInputs, FieldJobsAndRendersNeverWriteIntoTheScene) {
  TempDir tmp("outputs_scene");
  const std::string scene = tmp / "scene";
  copy_folder(lrf::test::synthetic_scene(), scene);
  const auto before = contents(scene);

  // --force would otherwise let a fresh run write its files into the scene folder.
  expect_refused("train " + quoted(scene) + " --space rgb --steps 5 -o " + quoted(scene) + " --force");
  expect_refused("train " + quoted(scene) + " --space rgb --steps 5 -o " + quoted(scene + "/images/..") + " --force");
  // compare and pipeline would fill the scene folder with a subfolder per method and stage.
  expect_refused("compare " + quoted(scene) + " -o " + quoted(scene));
  const std::string other = tmp / "other";
  copy_folder(lrf::test::synthetic_scene(), other);
  expect_refused("pipeline --train-scenes " + quoted(other) + " --eval-scenes " + quoted(scene) + " -o " + quoted(scene));
  const std::string run = tmp / "run";
  auto trained = run_lrf("-q --threads 2 train " + quoted(scene) + " --space rgb --steps 5 -o " + quoted(run));
  ASSERT_EQ(trained.exit_code, 0) << trained.output;

  // Renders are named after the views: in the images folder they would replace the photos.
  expect_refused("render " + quoted(run) + " -o " + quoted(scene + "/images"));
  expect_refused("render " + quoted(run) + " --split all -o " + quoted(scene));
  expect_refused("render " + quoted(run) + " --path orbit --frames 2 --frames-dir " + quoted(scene + "/images"));
  // Nor does triangulation write over the points the scene came with.
  expect_refused("scene points " + quoted(scene) + " -o " + quoted(scene + "/sparse/0/points3D.txt"));
  EXPECT_EQ(contents(scene), before) << "the scene is unchanged";

  const auto ok = run_lrf("-q render " + quoted(run) + " -o " + quoted(tmp / "renders"));
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_FALSE(fs::is_empty(tmp / "renders"));
}

TEST(OutputsOverInputs, RefineAndFinetuningNeverWriteOverTheirInputs) {
  TempDir tmp("outputs_runs");
  const std::string field = tmp / "field";
  copy_folder(lrf::test::tiny_field("latent"), field);
  lrf::StateDict weights;
  weights.insert("w", torch::zeros({2}));
  const std::string start = tmp / "start.safetensors";
  lrf::write_safetensors(start, weights, {});
  const auto before = contents(field), weights_before = contents(start);

  const auto refine = run_lrf("-q refine " + quoted(field) + " -o " + quoted(field + "/.") + " --force --steps 2");
  EXPECT_EQ(refine.exit_code, 1) << refine.output;
  EXPECT_NE(refine.output.find("refine writes a new run"), std::string::npos) << refine.output;
  // The field's scene, found at a copy with --scene, is no output folder either.
  const std::string scene = tmp / "scene";
  copy_folder(lrf::test::synthetic_scene(), scene);
  const auto scene_before = contents(scene);
  expect_refused("refine " + quoted(field) + " --scene " + quoted(scene) + " -o " + quoted(scene) + " --force --steps 2");
  EXPECT_EQ(contents(scene), scene_before);
  expect_refused("finetune-encoder --scenes " + quoted(lrf::test::synthetic_scene()) + " --autoencoder " + taef2() +
                 " --encoder " + quoted(start) + " -o " + quoted(start) + " --force --steps 1");
  expect_refused("finetune-decoder --fields " + quoted(field) + " --autoencoder " + taef2() + " --decoder " +
                 quoted(start) + " -o " + quoted(tmp / "./start.safetensors") + " --force --steps 1");
  EXPECT_EQ(contents(field), before) << "the field is unchanged";
  EXPECT_EQ(contents(start), weights_before) << "the weights are unchanged";
}

}  // namespace
