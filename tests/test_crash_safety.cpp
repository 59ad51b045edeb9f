// Crash safety of training jobs: an output folder is locked against a second concurrent job (and the lock
// dies with its process), and `lrf train` killed with SIGKILL mid-way then resumed with --resume ends
// with the same field and metrics as an uninterrupted run of the same seed.
#include <chrono>
#include <cstdio>
#include <csignal>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/folder_lock.h"
#include "lrf/core/run_info.h"
#include "lrf/finetune/decoder_finetune.h"
#include "lrf/finetune/encoder_finetune.h"
#include "test_helpers.h"

extern char** environ;

namespace fs = std::filesystem;

namespace {

// `lrf ARGS...` as a child process (output to `log`); returns its PID.
pid_t spawn_lrf(const std::vector<std::string>& args, const std::string& log) {
  std::vector<std::string> all = {LRF_BINARY};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  int rc = posix_spawn(&pid, LRF_BINARY, &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

std::string quote(const std::string& s) { return "'" + s + "'"; }

// Train settings shared by the runs: small, with a checkpoint every 25 of 150 steps.
std::string train_args(const std::string& scene, const std::string& out) {
  return "--threads 2 -q train " + quote(scene) + " -o " + quote(out) +
         " --iters 150 --checkpoint-every 25 --sh-degree 1 --seed 5 --max-gaussians 4000";
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  bool in_quote = false;
  for (char c : s) {
    if (c == '\'') {
      in_quote = !in_quote;
    } else if (c == ' ' && !in_quote) {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

}  // namespace

TEST(FolderLock, SecondHolderIsRefusedNamingFolderAndPid) {
  lrf::test::TempDir dir("lock");
  {
    lrf::FolderLock lock(dir.str());
    // The same process opening it again is a second holder as well (flock is per open file).
    std::string msg = lrf::test::error_of([&] { lrf::FolderLock again(dir.str()); });
    EXPECT_NE(msg.find(dir.str()), std::string::npos) << msg;
    EXPECT_NE(msg.find("PID " + std::to_string(::getpid())), std::string::npos) << msg;
  }
  // Released with its holder.
  EXPECT_EQ(lrf::test::error_of([&] { lrf::FolderLock again(dir.str()); }), "");
}

TEST(FolderLock, TrainIntoALockedFolderIsRefused) {
  const std::string scene = lrf::test::synthetic_scene({8, "64x48", 3, 800});
  lrf::test::TempDir dir("lock_train");
  const std::string out = dir / "out";
  fs::create_directories(out);
  lrf::FolderLock lock(out);
  auto r = lrf::test::run_lrf("train " + quote(scene) + " -o " + quote(out) + " --iters 10");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("in use by another lrf job"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(out), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("PID " + std::to_string(::getpid())), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(fs::path(out) / "config.json")) << "the refused job wrote into the folder";
}

TEST(FolderLock, SingleFileJobsAreRefusedWhileTheirOutputIsLocked) {
  lrf::test::TempDir dir("lock_file");
  const std::string out = dir / "enc.safetensors";
  const auto lock = lrf::FolderLock::for_output_file(out);
  EXPECT_TRUE(fs::exists(out + ".lock"));
  // Both fine-tuning jobs take the lock before touching anything, so the (missing) scene and fields
  // are never reached and the refusal names the output file and this process.
  lrf::EncoderFinetuneOptions enc;
  enc.scenes = {dir / "no-such-scene"};
  enc.out = out;
  enc.force = true;
  std::string msg = lrf::test::error_of([&] { lrf::finetune_encoder(enc); });
  EXPECT_NE(msg.find("output file is in use by another lrf job (PID " + std::to_string(::getpid()) + ")"),
            std::string::npos) << msg;
  EXPECT_NE(msg.find(out), std::string::npos) << msg;
  lrf::DecoderFinetuneOptions dec;
  dec.fields = {dir / "no-such-field"};
  dec.out = out;
  dec.force = true;
  msg = lrf::test::error_of([&] { lrf::finetune_decoder(dec); });
  EXPECT_NE(msg.find("in use by another lrf job"), std::string::npos) << msg;
  EXPECT_FALSE(fs::exists(out));
}

TEST(CrashSafety, KilledTrainingResumesToTheUninterruptedResult) {
  const std::string scene = lrf::test::synthetic_scene({8, "64x48", 3, 800});
  lrf::test::TempDir dir("crash");
  const std::string straight = dir / "straight", killed = dir / "killed";

  // The interrupted run: SIGKILL as soon as its first checkpoint exists.
  const pid_t pid = spawn_lrf(split(train_args(scene, killed)), dir / "killed.log");
  ASSERT_GT(pid, 0);
  const std::string ckpt = (fs::path(killed) / "checkpoint.pt").string();
  auto start = std::chrono::steady_clock::now();
  int status = 0;
  bool exited = false;
  while (!fs::exists(ckpt)) {
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    ASSERT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(120)) << "no checkpoint written";
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_FALSE(exited) << "the run ended before it could be killed: " << lrf::read_file(dir / "killed.log");
  // Frozen at once: the 125 steps left take well under a second, less than starting the second job below.
  ASSERT_EQ(::kill(pid, SIGSTOP), 0);

  // While it holds the folder, a second job on it is refused, naming the folder and the PID holding it.
  auto second = lrf::test::run_lrf(train_args(scene, killed) + " --resume");
  EXPECT_NE(second.exit_code, 0);
  EXPECT_NE(second.output.find("in use by another lrf job (PID " + std::to_string(pid) + ")"), std::string::npos)
      << second.output;

  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "the run ended before it was killed";
  ASSERT_FALSE(lrf::read_json_file(killed + "/config.json").contains("result")) << "killed after it finished";

  // The kill released the lock: --resume takes the folder and finishes the run.
  auto resumed = lrf::test::run_lrf(train_args(scene, killed) + " --resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  auto uninterrupted = lrf::test::run_lrf(train_args(scene, straight));
  ASSERT_EQ(uninterrupted.exit_code, 0) << uninterrupted.output;

  // The same parameters, byte for byte.
  EXPECT_TRUE(lrf::read_file(straight + "/point_cloud.ply") == lrf::read_file(killed + "/point_cloud.ply"))
      << "the resumed run's field differs from the uninterrupted run's";
  auto a = lrf::read_json_file(straight + "/config.json")["result"];
  auto b = lrf::read_json_file(killed + "/config.json")["result"];
  EXPECT_EQ(a["steps"], 150);
  EXPECT_EQ(a["steps"], b["steps"]);
  EXPECT_EQ(a["gaussians"], b["gaussians"]);
  EXPECT_EQ(a["final_loss"], b["final_loss"]);
  // And the same metrics on the test views.
  for (const auto& out : {straight, killed}) {
    auto e = lrf::test::run_lrf("--threads 2 -q eval " + quote(out));
    ASSERT_EQ(e.exit_code, 0) << e.output;
  }
  auto ma = lrf::read_json_file(straight + "/metrics.json"), mb = lrf::read_json_file(killed + "/metrics.json");
  for (const char* key : {"psnr", "ssim"}) EXPECT_EQ(ma[key], mb[key]) << key;
}

namespace {

// Starts `lrf ARGS` and SIGKILLs it as soon as OUT/checkpoint.pt exists (the run must still be going then).
void kill_after_first_checkpoint(const std::string& args, const std::string& out, const std::string& log) {
  const pid_t pid = spawn_lrf(split(args), log);
  ASSERT_GT(pid, 0);
  const auto start = std::chrono::steady_clock::now();
  int status = 0;
  while (!fs::exists(fs::path(out) / "checkpoint.pt")) {
    ASSERT_NE(::waitpid(pid, &status, WNOHANG), pid) << "the run ended before it could be killed: " << lrf::read_file(log);
    ASSERT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(120)) << "no checkpoint written";
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "the run ended before it was killed";
}

}  // namespace

// A feature field (feature-gs) keeps its lift's optimizer state beside the field's checkpoint: killed and
// resumed, it ends with the same Gaussians and the same lift as an uninterrupted run.
TEST(CrashSafety, KilledFeatureFieldResumesToTheUninterruptedResult) {
  const std::string scene = lrf::test::synthetic_scene({16, "128x96", 7, 1500});
  lrf::test::TempDir dir("crash_feature");
  const std::string straight = dir / "straight", killed = dir / "killed";
  auto args = [&](const std::string& out) {
    return "--threads 2 -q train " + quote(scene) + " -o " + quote(out) + " --space latent --feature-dim 8 --iters 300 "
           "--checkpoint-every 25 --seed 5 --cache-dir " + quote(dir / "cache");
  };
  // The uninterrupted run first: it also fills the latent cache, so that the killed run starts training at once.
  auto uninterrupted = lrf::test::run_lrf(args(straight));
  ASSERT_EQ(uninterrupted.exit_code, 0) << uninterrupted.output;
  ASSERT_NO_FATAL_FAILURE(kill_after_first_checkpoint(args(killed), killed, dir / "killed.log"));
  ASSERT_FALSE(lrf::read_json_file(killed + "/config.json").contains("result")) << "killed after it finished";
  auto resumed = lrf::test::run_lrf(args(killed) + " --resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  for (const char* file : {"point_cloud.ply", "lift.safetensors"}) {
    EXPECT_TRUE(lrf::read_file(straight + "/" + file) == lrf::read_file(killed + "/" + file))
        << file << " of the resumed run differs from the uninterrupted run's";
  }
  EXPECT_EQ(lrf::read_json_file(straight + "/config.json")["result"]["final_loss"],
            lrf::read_json_file(killed + "/config.json")["result"]["final_loss"]);
}

// A disk that fills while training writes its checkpoint: simulated with a file-size limit (writes past it
// fail with EFBIG, SIGXFSZ ignored, as a full disk fails them with ENOSPC). The run stops with an error
// naming the checkpoint, exit 1, no temporary left behind; the previous checkpoint survives, and a retry
// with room resumes from it. Temporaries left by a killed write are removed by the next run on the folder.
TEST(CrashSafety, FullDiskWhileCheckpointingIsAnErrorAndLeavesNothingBehind) {
  const std::string scene = lrf::test::synthetic_scene({8, "64x48", 3, 800});
  lrf::test::TempDir dir("disk_full");
  const std::string out = dir / "run";
  // Its first 25 steps, then the checkpoint every 25 more.
  const std::string args = "--threads 2 -q train " + quote(scene) + " -o " + quote(out) +
                           " --checkpoint-every 25 --sh-degree 1 --seed 5 --max-gaussians 4000 --iters ";
  auto first = lrf::test::run_lrf(args + "25");
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const std::string ckpt = out + "/checkpoint.pt";
  const std::string before = lrf::read_file(ckpt);
  ASSERT_GT(before.size(), 40000u);
  // A killed write's temporary, as a crash leaves it.
  lrf::write_file_atomic(out + "/point_cloud.ply.tmp1a2b3c", "half a file");
  // Resumed with files limited to 32 KB: the next checkpoint cannot be written.
  const std::string limited = "bash -c \"trap '' XFSZ; ulimit -f 32; exec " + std::string(LRF_BINARY) + " " +
                              args + "150 --resume\" 2>&1";
  std::string output;
  FILE* p = ::popen(limited.c_str(), "r");
  ASSERT_NE(p, nullptr);
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) output.append(buf, n);
  const int status = ::pclose(p);
  ASSERT_TRUE(WIFEXITED(status)) << output;
  EXPECT_EQ(WEXITSTATUS(status), 1) << output;
  EXPECT_NE(output.find("checkpoint.pt"), std::string::npos) << output;
  EXPECT_NE(output.find("File too large"), std::string::npos) << output;
  EXPECT_EQ(output.find("terminate"), std::string::npos) << output;  // no uncaught exception
  for (const auto& e : fs::directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << "left behind: " << e.path();
  EXPECT_TRUE(lrf::read_file(ckpt) == before) << "the previous checkpoint was damaged";
  // With room again, the run resumes from it and finishes.
  auto retry = lrf::test::run_lrf(args + "150 --resume");
  EXPECT_EQ(retry.exit_code, 0) << retry.output;
  EXPECT_TRUE(fs::exists(out + "/point_cloud.ply"));
}
