// The shared worker pool (runtime/src/parallel/pool.h): every item runs exactly once on a valid
// worker for any thread count, the first failing item in item order is the one reported, nested and
// concurrent calls complete, and the pool stays usable after a failure.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include "parallel/memory.h"
#include "parallel/pool.h"

namespace vlt::parallel_internal {
namespace {

TEST(ParallelForEach, RunsEveryItemOnceOnAValidWorker) {
  for (const int threads : {1, 2, 3, 8}) {
    for (const std::size_t count : {std::size_t{0}, std::size_t{1}, std::size_t{3}, std::size_t{1000}}) {
      std::vector<std::atomic<int>> runs(count);
      std::atomic<int> bad_worker{0};
      const int max_worker = static_cast<int>(std::min<std::size_t>(threads, count));
      ForEach(count, threads, [&](std::size_t item, int worker) {
        runs[item].fetch_add(1);
        if (worker < 0 || worker >= max_worker) bad_worker.fetch_add(1);
      });
      for (std::size_t i = 0; i < count; ++i)
        EXPECT_EQ(runs[i].load(), 1) << "threads " << threads << " item " << i;
      EXPECT_EQ(bad_worker.load(), 0) << "threads " << threads << " count " << count;
    }
  }
}

TEST(ParallelForEach, ChunksCoverTheRangeInOrder) {
  for (const int threads : {1, 2, 4}) {
    for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{64}, std::size_t{1001}}) {
      std::vector<int> covered(n, 0);
      const std::size_t chunk = 64;
      std::vector<std::size_t> begins((n + chunk - 1) / chunk, 0), ends(begins.size(), 0);
      ForEachChunk(n, chunk, threads, [&](std::size_t c, std::size_t begin, std::size_t end) {
        begins[c] = begin;
        ends[c] = end;
        for (std::size_t i = begin; i < end; ++i) ++covered[i];  // chunks are disjoint: no race
      });
      for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(covered[i], 1);
      for (std::size_t c = 0; c < begins.size(); ++c) {
        EXPECT_EQ(begins[c], c * chunk);
        EXPECT_EQ(ends[c], std::min(n, (c + 1) * chunk));
      }
    }
  }
}

// Items 37 and 700 fail; item 37 is reported for every thread count and every repetition, and the
// pool serves the next call normally.
TEST(ParallelForEach, ReportsTheFirstFailingItemInItemOrder) {
  for (const int threads : {1, 2, 4}) {
    for (int repeat = 0; repeat < 50; ++repeat) {
      std::string message;
      try {
        ForEach(1000, threads, [&](std::size_t item, int) {
          if (item == 700 || item == 37) throw std::runtime_error("item " + std::to_string(item));
        });
      } catch (const std::runtime_error& e) {
        message = e.what();
      }
      EXPECT_EQ(message, "item 37") << "threads " << threads;
      std::atomic<std::size_t> sum{0};
      ForEach(100, threads, [&](std::size_t item, int) { sum.fetch_add(item); });
      EXPECT_EQ(sum.load(), 99u * 100u / 2u);
    }
  }
}

TEST(ParallelForEach, NestedCallsRunInline) {
  std::atomic<int> inner{0};
  ForEach(8, 2, [&](std::size_t, int) {
    ForEach(10, 2, [&](std::size_t, int worker) {
      EXPECT_EQ(worker, 0);  // on the calling thread
      inner.fetch_add(1);
    });
  });
  EXPECT_EQ(inner.load(), 80);
}

TEST(ParallelForEach, CallsFromSeveralThreadsAreServed) {
  std::atomic<long> total{0};
  std::vector<std::thread> callers;
  for (int c = 0; c < 3; ++c) {
    callers.emplace_back([&] {
      for (int call = 0; call < 200; ++call) {
        ForEach(64, 2, [&](std::size_t item, int) { total.fetch_add(static_cast<long>(item)); });
      }
    });
  }
  for (std::thread& t : callers) t.join();
  EXPECT_EQ(total.load(), 3L * 200L * (63L * 64L / 2L));
}

// fork copies only the calling thread: in the child the pool's workers do not exist, and ForEach
// must still run every item (inline) instead of waiting for them.
TEST(ParallelForEach, WorksInAChildForkedAfterTheWorkersStarted) {
  std::atomic<int> before{0};
  ForEach(100, 2, [&](std::size_t, int) { before.fetch_add(1); });
  ASSERT_EQ(before.load(), 100);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    std::atomic<int> runs{0};
    ForEach(1000, 2, [&](std::size_t, int) { runs.fetch_add(1); });
    _exit(runs.load() == 1000 ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
}

// MapPages maps every whole page of its range and nothing outside it: a 16 MiB area between two
// inaccessible guard pages, the range starting and ending inside a page; residency from mincore.
// (Huge pages off for the area, so that a page is mapped alone.) Where the kernel lacks
// MADV_POPULATE_WRITE (before 5.14) the test is skipped: MapPages then does nothing by design.
TEST(ParallelMemory, MapPagesMapsTheWholePagesOfItsRangeAndNothingElse) {
  const std::size_t page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  const std::size_t pages = (std::size_t{16} << 20) / page;
  void* mapped = mmap(nullptr, (pages + 2) * page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(mapped, MAP_FAILED);
  char* area = static_cast<char*>(mapped);
  madvise(area, (pages + 2) * page, MADV_NOHUGEPAGE);
  ASSERT_EQ(mprotect(area, page, PROT_NONE), 0);
  ASSERT_EQ(mprotect(area + (pages + 1) * page, page, PROT_NONE), 0);
  char* begin = area + page;
  auto resident = [&] {
    std::vector<unsigned char> in(pages);
    EXPECT_EQ(mincore(begin, pages * page, in.data()), 0);
    std::vector<bool> r(pages);
    for (std::size_t p = 0; p < pages; ++p) r[p] = (in[p] & 1) != 0;
    return r;
  };
  const std::vector<bool> before = resident();
  ASSERT_EQ(std::count(before.begin(), before.end(), true), 0);
  // Whether this kernel (and C library) has it: a probe on a page of its own.
  bool supported = false;
#ifdef MADV_POPULATE_WRITE
  if (void* probe = mmap(nullptr, page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      probe != MAP_FAILED) {
    supported = madvise(probe, page, MADV_POPULATE_WRITE) == 0;
    munmap(probe, page);
  }
#endif
  if (!supported) {
    munmap(mapped, (pages + 2) * page);
    GTEST_SKIP() << "this kernel has no MADV_POPULATE_WRITE";
  }
  MapPages(begin + 100, pages * page - 200, 2);
  const std::vector<bool> r = resident();
  EXPECT_FALSE(r[0]) << "the first page is only partly in the range";
  EXPECT_FALSE(r[pages - 1]) << "the last page is only partly in the range";
  for (std::size_t p = 1; p + 1 < pages; ++p) ASSERT_TRUE(r[p]) << "page " << p;
  for (std::size_t i = page; i < pages * page; i += page) ASSERT_EQ(begin[i], 0);  // still zero
  munmap(mapped, (pages + 2) * page);
}

}  // namespace
}  // namespace vlt::parallel_internal
