// The loop every resumable training job shares (core/run_loop.h) and the CSV log a resumed run continues
// (core/train_log.h): when checkpoints are written, what a stop request leaves, and which rows survive a
// resume. The jobs' own end-to-end tests (test_stop_request, test_rgb_run, test_latent_nerf, the
// fine-tuning tests) exercise the same rules through the CLI.
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/run_loop.h"
#include "lrf/core/stop_request.h"
#include "lrf/core/train_log.h"
#include "test_helpers.h"

namespace {

// A job of `total` steps that records after which step each save happened, and asks to stop after `stop_at`.
struct CountingJob {
  int64_t done = 0;
  std::vector<int64_t> saves;
  int64_t steps_made = 0;
  lrf::RunLoop loop(int64_t total, int64_t first, int64_t every, int64_t stop_at = -1) {
    done = first;
    lrf::RunLoop l;
    l.total_steps = total;
    l.first_step = first;
    l.checkpoint_every = every;
    l.checkpoint = "ckpt.pt";
    l.step = [this] {
      ++steps_made;
      return lrf::LoopStep{++done, {{"loss", 1.0}}};
    };
    l.save = [this] { saves.push_back(done); };
    l.stop_requested = [this, stop_at] { return done == stop_at; };
    return l;
  }
};

TEST(RunLoop, SavesEveryCheckpointIntervalAndOnceAtTheEnd) {
  CountingJob job;
  EXPECT_EQ(lrf::run_loop(job.loop(10, 0, 4)), 10);
  EXPECT_EQ(job.saves, (std::vector<int64_t>{4, 8, 10}));
  EXPECT_EQ(job.steps_made, 10);
}

TEST(RunLoop, AnIntervalThatDividesTheTotalStillSavesTheLastStepOnce) {
  CountingJob job;
  lrf::run_loop(job.loop(8, 0, 4));
  EXPECT_EQ(job.saves, (std::vector<int64_t>{4, 8}));
}

TEST(RunLoop, NoIntervalSavesOnlyAtTheEnd) {
  CountingJob job;
  lrf::run_loop(job.loop(7, 0, 0));
  EXPECT_EQ(job.saves, (std::vector<int64_t>{7}));
}

TEST(RunLoop, AResumedRunMakesOnlyTheStepsLeft) {
  CountingJob job;
  EXPECT_EQ(lrf::run_loop(job.loop(10, 6, 4)), 10);
  EXPECT_EQ(job.steps_made, 4);
  EXPECT_EQ(job.saves, (std::vector<int64_t>{8, 10}));
  // Resumed at its end: nothing to make, the result written again.
  CountingJob finished;
  lrf::run_loop(finished.loop(10, 10, 4));
  EXPECT_EQ(finished.steps_made, 0);
  EXPECT_EQ(finished.saves, (std::vector<int64_t>{10}));
}

TEST(RunLoop, AStopRequestSavesThatStepThenThrowsInterruptedNamingIt) {
  CountingJob job;
  try {
    lrf::run_loop(job.loop(10, 0, 4, 3));
    FAIL() << "no Interrupted";
  } catch (const lrf::Interrupted& e) {
    EXPECT_EQ(e.exit_status(), 130);  // SIGINT when the request came from elsewhere than a signal
    EXPECT_NE(std::string(e.what()).find("after step 3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("ckpt.pt"), std::string::npos) << e.what();
  }
  EXPECT_EQ(job.saves, (std::vector<int64_t>{3}));
  EXPECT_EQ(job.steps_made, 3);
}

TEST(RunLoop, AStopRequestOnACheckpointStepSavesOnce) {
  CountingJob job;
  EXPECT_THROW(lrf::run_loop(job.loop(10, 0, 4, 4)), lrf::Interrupted);
  EXPECT_EQ(job.saves, (std::vector<int64_t>{4}));
}

TEST(RunLoop, AStopRequestAfterTheLastStepLetsTheRunFinish) {
  CountingJob job;
  EXPECT_EQ(lrf::run_loop(job.loop(5, 0, 0, 5)), 5);
  EXPECT_EQ(job.saves, (std::vector<int64_t>{5}));
}

TEST(RunLoop, AFailingStepPassesThroughWithoutASave) {
  CountingJob job;
  lrf::RunLoop l = job.loop(10, 0, 2);
  auto step = l.step;
  l.step = [&, step] {
    if (job.done == 5) throw lrf::Error("diverged");
    return step();
  };
  EXPECT_THROW(lrf::run_loop(l), lrf::Error);
  EXPECT_EQ(job.saves, (std::vector<int64_t>{2, 4}));
}

TEST(TrainLog, AResumeKeepsTheRowsUpToTheCheckpointAndContinuesTheirElapsedTime) {
  lrf::test::TempDir tmp("train_log");
  const std::string path = tmp / "train_log.csv";
  lrf::write_file_atomic(path, "step,loss,elapsed_s\n10,0.5,1.5\n20,0.4,3.25\n30,0.3,5\n");
  lrf::TrainLog log(path, "step,loss,elapsed_s", 2);
  EXPECT_DOUBLE_EQ(log.resume(20), 3.25);
  log.add("30,0.35,4.5");
  log.write();
  EXPECT_EQ(lrf::read_file(path), "step,loss,elapsed_s\n10,0.5,1.5\n20,0.4,3.25\n30,0.35,4.5\n");
  // Resumed before its first row: an empty log, no elapsed time.
  lrf::TrainLog again(path, "step,loss,elapsed_s", 2);
  EXPECT_DOUBLE_EQ(again.resume(5), 0);
  again.write();
  EXPECT_EQ(lrf::read_file(path), "step,loss,elapsed_s\n");
}

TEST(TrainLog, AMissingFileOrACutRowLeavesOnlyTheRowsBeforeIt) {
  lrf::test::TempDir tmp("train_log_cut");
  const std::string path = tmp / "curve.csv";
  lrf::TrainLog none(path, "step,psnr");
  EXPECT_DOUBLE_EQ(none.resume(100), 0);
  none.write();
  EXPECT_EQ(lrf::read_file(path), "step,psnr\n");
  lrf::write_file_atomic(path, "step,psnr\n10,20.5\n\n20,21\n,garbled\n30,22\n");
  lrf::TrainLog cut(path, "step,psnr");
  cut.resume(100);
  cut.write();
  EXPECT_EQ(lrf::read_file(path), "step,psnr\n10,20.5\n20,21\n");
}

}  // namespace
