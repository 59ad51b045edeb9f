#include <filesystem>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/resources.h"
#include "test_helpers.h"

TEST(Resources, PeakMemoryFollowsAnAllocation) {
  // The peak is at least every earlier resident size (read the current size first: reading the status
  // file itself may add a page).
  double current = lrf::current_memory_mb();
  double before = lrf::peak_memory_mb();
  ASSERT_GT(current, 1.0);  // a running gtest binary with libtorch is tens of MB
  EXPECT_GE(before, current);
  {
    // Touch 64 MiB so that it becomes resident: the peak must reach about that much above the current size,
    // whatever earlier tests in this process left as the peak. The 48 MiB bound leaves room for pages that
    // were already resident (freed heap being reused).
    std::vector<char> block(64u << 20);
    for (size_t i = 0; i < block.size(); i += 4096) block[i] = static_cast<char>(i);
    volatile char sink = block[block.size() / 2];
    (void)sink;
    EXPECT_GT(lrf::peak_memory_mb(), current + 48.0);
    EXPECT_GE(lrf::peak_memory_mb(), before);
  }
  // After the block is freed, a reset brings the peak back near the current size (if the kernel allows).
  if (lrf::reset_peak_memory()) {
    EXPECT_LT(lrf::peak_memory_mb(), lrf::current_memory_mb() + 16.0);
  }
}

TEST(Resources, DirectorySizeCountsFilesOnce) {
  lrf::test::TempDir dir("resources_size");
  std::filesystem::create_directories(dir / "sub");
  lrf::write_file_atomic(dir / "a.bin", std::string(1 << 20, 'a'));          // 1 MiB
  lrf::write_file_atomic(dir / "sub/b.bin", std::string(512 * 1024, 'b'));   // 0.5 MiB
  std::filesystem::create_symlink(dir / "a.bin", dir / "link.bin");           // not counted again
  EXPECT_DOUBLE_EQ(lrf::directory_size_mb(dir.str()), 1.5);
  EXPECT_DOUBLE_EQ(lrf::directory_size_mb(dir / "sub/b.bin"), 0.5);
  EXPECT_THROW(lrf::directory_size_mb(dir / "missing"), lrf::Error);
}

TEST(Resources, StopwatchMeasuresWallTime) {
  lrf::Stopwatch watch;
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  double t = watch.seconds();
  EXPECT_GE(t, 0.03);
  EXPECT_LT(t, 5.0);  // generous: the machine is shared
  watch.reset();
  EXPECT_LT(watch.seconds(), t);
}
