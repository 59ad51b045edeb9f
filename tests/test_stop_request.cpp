// Ctrl-C (SIGINT) and SIGTERM used to kill `lrf train` at once, losing every step since the last checkpoint:
// now the training loop stops at its next step, writes a checkpoint, exits with 128 + the signal, and
// --resume continues from there.
#include <chrono>
#include <csignal>
#include <filesystem>
#include <regex>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "child_process.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/run_info.h"
#include "test_helpers.h"

namespace fs = std::filesystem;

namespace {

// Starts `lrf train` on the synthetic scene for (practically) ever, with no periodic checkpoint, sends it
// `signal` once its training loop reports progress, and returns its exit status; *log gets its stderr.
int train_then_signal(const std::string& out, const std::string& log_path, int signal, bool resume) {
  std::vector<std::string> argv = {LRF_BINARY, "--threads", "2", "--log-json", "train", lrf::test::synthetic_scene(),
                                   "-o", out, "--iters", "100000000", "--checkpoint-every", "100000000",
                                   "--sh-degree", "1", "--max-gaussians", "2000"};
  if (resume) argv.push_back("--resume");
  fs::remove(log_path);  // the previous run's progress must not count as this one's
  lrf::test::ChildProcess lrf(argv, false, log_path);
  const auto start = std::chrono::steady_clock::now();
  // A progress line comes from inside the training loop, where the signals only ask to stop.
  while (!fs::exists(log_path) || lrf::read_file(log_path).find("\"task\":\"train\"") == std::string::npos) {
    if (std::chrono::steady_clock::now() - start > std::chrono::seconds(120)) return -2;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ::kill(lrf.pid(), signal);
  return lrf.wait(60);
}

// The step the run stopped after, from its "stopped by SIG... after step N" warning (-1 when none).
long stopped_step(const std::string& log, const std::string& signal) {
  std::smatch m;
  if (!std::regex_search(log, m, std::regex("stopped by " + signal + " after step (\\d+); \\S*checkpoint.pt holds it: "
                                            "continue with --resume")))
    return -1;
  return std::stol(m[1]);
}

TEST(StopRequest, SignalsStopTrainingWithACheckpointThatResumeContinues) {
  lrf::test::TempDir tmp("stop_request");
  const std::string out = tmp / "out", log = tmp / "train.log";

  ASSERT_EQ(train_then_signal(out, log, SIGINT, false), 130) << lrf::read_file(log);
  const long first = stopped_step(lrf::read_file(log), "SIGINT");
  ASSERT_GT(first, 0) << lrf::read_file(log);
  EXPECT_TRUE(fs::exists(out + "/checkpoint.pt"));
  EXPECT_TRUE(fs::exists(out + "/point_cloud.ply"));
  EXPECT_FALSE(lrf::read_json_file(out + "/config.json").contains("result"));

  // SIGTERM (what `kill` and service managers send) does the same, with its own status; the resumed run
  // starts where the first one stopped.
  ASSERT_EQ(train_then_signal(out, log, SIGTERM, true), 143) << lrf::read_file(log);
  EXPECT_NE(lrf::read_file(log).find("resuming " + out + " at step " + std::to_string(first)), std::string::npos);
  const long second = stopped_step(lrf::read_file(log), "SIGTERM");
  ASSERT_GT(second, first) << lrf::read_file(log);

  auto finish = lrf::test::run_lrf("--threads 2 -q train '" + lrf::test::synthetic_scene() + "' -o '" + out +
                                   "' --resume --iters " + std::to_string(second + 20));
  ASSERT_EQ(finish.exit_code, 0) << finish.output;
  EXPECT_EQ(lrf::read_json_file(out + "/config.json")["result"]["steps"], second + 20);
}

}  // namespace
