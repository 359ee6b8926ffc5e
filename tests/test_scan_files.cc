// test_scan_files.cc — the files of a scan (docs/results.md "Detail of the per-point files",
// issue 33): the compact numbers' rounding against printf's, the .npy header against the format's
// rules (numpy itself reads the files in tests/cli/check_points_npy.py), every parallel phase of a
// 10^5-point scan with work for 16 threads, and the same bytes for any thread count.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "base/format.h"
#include "base/npy.h"
#include "parallel/pool.h"
#include "vlt/job.h"
#include "vlt/results.h"

namespace vlt {
namespace {

std::string Decimals(double v, int decimals) {
  std::string s;
  base_internal::AppendDecimals(s, v, decimals);
  return s;
}

std::string RoundedUp(double v, int digits) {
  std::string s;
  base_internal::AppendRoundedUp(s, v, digits);
  return s;
}

// printf's %.Nf, then the trailing zeros (and point) dropped: the specification of AppendDecimals.
std::string DecimalsBySpecification(double v, int decimals) {
  char buffer[400];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, v);
  std::string s = buffer;
  if (decimals > 0) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  return s == "-0" ? "0" : s;
}

TEST(CompactNumbers, RoundLikePrintfWithoutTrailingZerosOrMinusZero) {
  EXPECT_EQ(Decimals(1500.2500000000002, 4), "1500.25");
  EXPECT_EQ(Decimals(-1987.34177215, 4), "-1987.3418");
  EXPECT_EQ(Decimals(-0.00001, 4), "0");
  EXPECT_EQ(Decimals(2000.0, 4), "2000");
  // Uncertainties: up, never down (JCGM 100 7.2.6), trailing zeros kept.
  EXPECT_EQ(RoundedUp(21.2345, 3), "21.3");
  EXPECT_EQ(RoundedUp(21.2, 3), "21.2");  // 212 exactly (21.2 * 10 rounds to 212.0)
  EXPECT_EQ(RoundedUp(81.0, 3), "81.0");
  EXPECT_EQ(RoundedUp(0.0123401, 3), "0.0124");
  EXPECT_EQ(RoundedUp(9.9951, 3), "10.00");
  EXPECT_EQ(RoundedUp(1234.2, 3), "1235");  // never an exponent: at least units
  EXPECT_EQ(RoundedUp(0.0, 3), "0");
  std::uint64_t state = 0x243f6a8885a308d3ull;
  for (int i = 0; i < 20000; ++i) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    const double v = (static_cast<double>(state >> 11) * 0x1p-53 - 0.5) * std::pow(10.0, (state & 15) - 6.0);
    for (const int d : {0, 1, 3, 4, 6}) ASSERT_EQ(Decimals(v, d), DecimalsBySpecification(v, d)) << v;
  }
}

TEST(NpyHeader, AlignedEscapedAndVersionedAsTheFormatSays) {
  base_internal::NpyLayout layout;
  layout.AddBytes("name", 12);
  layout.AddDoubles("covariance", {3, 3});
  layout.AddDoubles("a'b\\c", {3});
  layout.AddBool("ok");
  EXPECT_EQ(layout.record_size(), 12u + 72u + 24u + 1u);
  const std::string h = layout.Header(7);
  EXPECT_EQ(h.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  const std::size_t len = static_cast<unsigned char>(h[8]) + 256u * static_cast<unsigned char>(h[9]);
  EXPECT_EQ(h.size(), 10 + len);
  EXPECT_EQ(h.size() % 64, 0u);  // numpy.lib.format ARRAY_ALIGN
  EXPECT_EQ(h.back(), '\n');
  EXPECT_NE(h.find("('covariance', '<f8', (3, 3))"), std::string::npos) << h;
  EXPECT_NE(h.find(R"(('a\'b\\c', '<f8', (3,)))"), std::string::npos) << h;
  EXPECT_NE(h.find("'shape': (7,)"), std::string::npos) << h;
  base_internal::NpyLayout utf8;
  utf8.AddDoubles("\xc2\xb5m");  // "µm": a version 3.0 header, UTF-8
  const std::string h3 = utf8.Header(1);
  EXPECT_EQ(h3[6], '\x03');
  EXPECT_EQ(h3.size() % 64, 0u);
}

// A scan of n points on a 2.5 m x 2 m panel, 3 m to 5.5 m from a mirror tracker, one plane over
// all of them, GUM only.
Job ScanJob(std::size_t n) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "vlt_test_scan_files";
  std::filesystem::create_directories(dir);
  const std::filesystem::path csv = dir / ("scan" + std::to_string(n) + ".csv");
  {
    std::ofstream out(csv);
    out << "name,x,y,z\n";
    const std::size_t side = static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(n))));
    for (std::size_t i = 0; i < n; ++i) {
      out << "S" << i << "," << 3.0 + 2.5 * static_cast<double>(i % side) / side << ","
          << -1.0 + 2.0 * static_cast<double>(i / side) / side << ",0.4\n";
    }
  }
  const std::string text = R"(
[job]
name = "scan"
[tracker]
model = "mirror"
[tracker.noise]
range = "5 um + 0.5 um/m"
azimuth = "0.5 arcsec"
elevation = "0.5 arcsec"
[plan]
csv = ")" + csv.filename().string() +
                           R"("
[[task]]
kind = "plane"
name = "skin"
points = "all"
[monte_carlo]
enabled = false
[output]
arrays = true
)";
  return ParseJob(text, (dir / "scan.toml").string(), dir);
}

// The per-point files of a scan: the compact points.csv and points.npy.
std::string PerPointFiles(const Results& r) {
  StringText text;
  WriteCompactPointsCsv(r, text);
  WritePointsNpy(r, text);
  return std::move(text.text());
}

TEST(ScanFiles, EveryParallelPhaseOfA1e5PointScanOffersEightItemsToEachOfSixteenThreads) {
  const Job job = ScanJob(100000);
  RunOptions options;
  options.threads = 16;
  std::vector<std::size_t> counts;
  parallel_internal::RecordItemCounts(&counts);
  const Results r = RunJob(job, options);
  EXPECT_EQ(r.detail, PointDetail::kCompact);  // auto: above kFullDetailMaxPoints
  const std::string files = PerPointFiles(r);
  parallel_internal::RecordItemCounts(nullptr);
  ASSERT_GE(counts.size(), 5u);  // the GUM's blocks, second order, the task, the files' blocks
  for (std::size_t i = 0; i < counts.size(); ++i) {
    // One item is one computation, not a phase cut too coarsely: the budget of the first point,
    // which names the budget fields of points.npy.
    if (counts[i] == 1) continue;
    EXPECT_GE(counts[i], 8u * 16u) << "phase " << i << " of " << counts.size() << ": " << counts[i]
                                   << " items";
  }
  EXPECT_GT(files.size(), 100000u * 1000u);  // the npy records hold every budget
}

TEST(ScanFiles, SameBytesForOneTwoThreeAndSixteenThreads) {
  const Job job = ScanJob(20000);
  std::string reference;
  for (const int threads : {1, 2, 3, 16}) {
    RunOptions options;
    options.threads = threads;
    const Results r = RunJob(job, options);
    std::string files = PerPointFiles(r) + TasksCsv(r);
    if (threads == 1) {
      reference = std::move(files);
    } else {
      EXPECT_TRUE(files == reference) << threads << " threads";
    }
  }
}

}  // namespace
}  // namespace vlt
