// Result statements (JCGM 100 7.2; results/statement.cc) and their rounding (7.2.6; base/format.h
// RoundLikeGum): against the examples of JCGM 100 7.2 and against a job's GUM values rounded here
// by hand.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "base/format.h"
#include "results/internal.h"
#include "vlt/conformity.h"
#include "vlt/job.h"
#include "vlt/results.h"

namespace vlt {
namespace {

using base_internal::RoundLikeGum;

// The tracker of both jobs below: the demo's noise, the model's default parameters.
constexpr const char* kTracker = R"(
[tracker]
model = "mirror"
[tracker.noise]
range = "2.5 um + 0.3 um/m"
azimuth = "0.4 arcsec"
elevation = "0.4 arcsec"
)";

TEST(RoundLikeGum, TheExamplesOfJcgm100) {
  // 7.2.6: u = 10.47 mOhm "might be rounded up to 11 mOhm"; 28.05 kHz "should be rounded down to 28".
  EXPECT_EQ(RoundLikeGum(1.0, 1.0, 10.47e-3, 1e3).expanded, "11");
  EXPECT_EQ(RoundLikeGum(1.0, 1.0, 28.05e3, 1e-3).expanded, "28");
  // 7.2.4: m_S = (100.021 47 +- 0.000 79) g: with U = 0.000 79 g the value keeps 5 decimals (the
  // place of U's second digit); in mg and g as the GUM's own text shows them.
  const base_internal::GumRounded m = RoundLikeGum(100.02147e-3, 1e3, 0.79e-6, 1e6);
  EXPECT_EQ(m.expanded, "0.79");
  EXPECT_EQ(m.value, "100.02147");
  EXPECT_EQ(m.value_decimals, 5);
  // Lengths as vlt states them: value in mm, U in um. 13.2 um -> 14 um, the value to 1 um.
  const base_internal::GumRounded l = RoundLikeGum(4.0000132, 1e3, 13.2e-6, 1e6);
  EXPECT_EQ(l.expanded, "14");
  EXPECT_EQ(l.value, "4000.013");
  // 5.43 um -> 5.5 um and the value to 0.1 um; 99.2 um -> 100 um (two digits: 1.0e2), value to 10 um.
  EXPECT_EQ(RoundLikeGum(0.05, 1e3, 5.43e-6, 1e6).value, "50.0000");
  EXPECT_EQ(RoundLikeGum(0.05, 1e3, 5.43e-6, 1e6).expanded, "5.5");
  const base_internal::GumRounded hundred = RoundLikeGum(1.23456, 1e3, 99.2e-6, 1e6);
  EXPECT_EQ(hundred.expanded, "100");
  EXPECT_EQ(hundred.value, "1234.56");
  // Limits as specified: the shortest digits of the SI value, the decimal point moved.
  EXPECT_EQ(base_internal::ShortestAt(3.9999905, 1e3), "3999.9905");
  EXPECT_EQ(base_internal::ShortestAt(0.99999999996, 1.0), "0.99999999996");
  EXPECT_EQ(base_internal::ShortestAt(-1.5e-5, 1e3), "-0.015");
  EXPECT_EQ(base_internal::ShortestAt(2.0, 1e6), "2000000");
  EXPECT_EQ(base_internal::ShortestAt(0.0, 1e3), "0");
  // A limit typed in mm is held in m with the conversion's rounding (300.05 * 1e-3 is
  // 0.30005000000000004): it comes back as typed, not with 17 digits; a typed limit with 15
  // significant digits keeps them all.
  EXPECT_EQ(0.30005000000000004, 300.05 * 1e-3);
  EXPECT_EQ(base_internal::ShortestAt(300.05 * 1e-3, 1e3), "300.05");
  EXPECT_EQ(base_internal::ShortestAt(0.1 + 0.2, 1.0), "0.3");
  EXPECT_EQ(base_internal::ShortestAt(-4000.01234567891 * 1e-3, 1e3), "-4000.01234567891");
  EXPECT_EQ(base_internal::ShortestAt(1.23456789012345e-7, 1e6), "0.123456789012345");
  // Far from 1: with an exponent, the shortest digits.
  EXPECT_EQ(base_internal::ShortestAt(5e-12, 1.0), "5e-12");
  EXPECT_EQ(base_internal::ShortestAt(-1.25e-9, 1e3), "-0.00000125");
  EXPECT_EQ(base_internal::ShortestAt(1.5e-7, 1.0), "1.5e-7");
  EXPECT_EQ(base_internal::ShortestAt(1.25e20, 1.0), "1.25e+20");
  EXPECT_EQ(base_internal::ShortestAt(9.9999999999999995, 1.0), "10");
  // The same in the conformity lines and reports (vlt/conformity.h).
  EXPECT_EQ(DescribeTolerance(Tolerance{299.95 * 1e-3, 300.05 * 1e-3}, 1e3, "mm"), "[299.95, 300.05] mm");
  EXPECT_EQ(DescribeTolerance(Tolerance{-std::numeric_limits<double>::infinity(), 0.05 * 1e-3}, 1e6, "µm"),
            "<= 50 µm");
  EXPECT_EQ(DescribeTolerance(Tolerance{1e-3, std::numeric_limits<double>::infinity()}, "m"), ">= 0.001 m");
  // No "-0": a value that rounds to 0 at U's place.
  EXPECT_EQ(RoundLikeGum(-3.8e-16, 1.0, 6.62e-6, 1.0).value, "0.0000000");
  EXPECT_EQ(RoundLikeGum(-3.8e-16, 1.0, 6.62e-6, 1.0).expanded, "0.0000067");
  // A U of 135.2 mm (beyond the units place): up to 140 mm, the value to 10 mm; 130.2 mm -> 130
  // (an excess of 2 % of the last digit is dropped).
  EXPECT_EQ(RoundLikeGum(12.3456, 1e3, 0.1352, 1e3).value, "12350");
  EXPECT_EQ(RoundLikeGum(12.3456, 1e3, 0.1352, 1e3).expanded, "140");
  EXPECT_EQ(RoundLikeGum(12.3456, 1e3, 0.1302, 1e3).expanded, "130");
}

// A distance with a tolerance, GUM and Monte Carlo: the statement is the GUM's value and U rounded
// here by hand (U between 10 and 100 um: up to whole um, the value to 0.001 mm), the Monte Carlo
// interval at the same decimals, and the ISO 14253-1 decision.
TEST(ResultStatements, ADistanceAsOneSignsIt) {
  const Job job = ParseJob(R"(
[job]
name = "bracket"
)" + std::string(kTracker) + R"([plan]
unit = "mm"
point = [ {name = "A", x = 3000, y = 500, z = 200}, {name = "B", x = 5000, y = -500, z = 200} ]
[[task]]
name = "AB"
kind = "distance"
points = ["A", "B"]
[task.tolerance.distance]
lower = "2236.00 mm"
upper = "2236.10 mm"
[monte_carlo]
trials = 20000
)",
                           "job.toml", std::filesystem::temp_directory_path());
  RunOptions options;
  options.threads = 2;
  const Results r = RunJob(job, options);
  const std::vector<results_internal::ResultStatement> statements = results_internal::ResultStatements(r);
  ASSERT_EQ(statements.size(), 1u);
  EXPECT_EQ(statements[0].task, "AB");
  EXPECT_EQ(statements[0].quantity, "distance");
  const double value = r.tasks[0].gum.value[0], u_um = r.tasks[0].gum.U[0] * 1e6;
  ASSERT_GT(u_um, 10.0);
  ASSERT_LT(u_um, 100.0);
  const double expanded = u_um - std::floor(u_um) <= 0.05 ? std::floor(u_um) : std::ceil(u_um);
  char expected[160];
  std::snprintf(
      expected, sizeof expected,
      "%.3f mm, U = %.0f µm (k = 1.96, p = 95 %%); Monte Carlo 95 %% coverage interval [%.3f, %.3f] mm",
      value * 1e3, expanded, r.tasks[0].mcm[0].symmetric.low * 1e3, r.tasks[0].mcm[0].symmetric.high * 1e3);
  EXPECT_EQ(statements[0].text.rfind(expected, 0), 0u)
      << statements[0].text << "\nexpected start: " << expected;
  // The limits as the job gives them ("2236.00 mm", "2236.10 mm": the shortest digits of the value).
  EXPECT_NE(statements[0].text.find("; conforms to [2236, 2236.1] mm (ISO 14253-1, guard band U"),
            std::string::npos)
      << statements[0].text;
}

// A plane in a wall x = 4 m: its normal_x = cos(tilt) varies at second order only (the GUM's u is 0
// to rounding). The statement leads with the Monte Carlo shortest interval, and the decision
// against normal_x >= 0.99999999996 uses it (undetermined: the interval crosses the limit), not a
// GUM guard band of 1e-20 (which said "conforms"); the limit is printed as specified. Without Monte
// Carlo the statement does not call it exact.
TEST(ResultStatements, SecondOrderOnlyQuantitiesAreStatedAndDecidedByMonteCarlo) {
  const std::string text = R"(
[job]
name = "wall"
)" + std::string(kTracker) +
                           R"([plan]
unit = "mm"
point = [ {name = "W00", x = 4000, y = -750, z = -800}, {name = "W01", x = 4000, y = -750, z = 200},
          {name = "W10", x = 4000, y = 750, z = -800}, {name = "W11", x = 4000, y = 750, z = 200},
          {name = "W20", x = 4000, y = 0, z = -300} ]
[[task]]
kind = "plane"
name = "wall"
points = ["W00", "W01", "W10", "W11", "W20"]
[task.tolerance.normal_x]
lower = 0.99999999996
[monte_carlo]
trials = 20000
seed = 1
)";
  const Job job = ParseJob(text, "job.toml", std::filesystem::temp_directory_path());
  RunOptions options;
  options.threads = 2;
  const Results r = RunJob(job, options);
  const TaskResult& wall = r.tasks[0];
  std::size_t q = 0;
  while (wall.gum.quantities[q] != "normal_x") ++q;
  ASSERT_EQ(wall.validation[q].outcome, "not applicable") << wall.validation[q].verdict;
  EXPECT_TRUE(results_internal::DecidedByMonteCarlo(wall, q));
  ASSERT_TRUE(wall.conformity[q]);
  const CoverageInterval& ci = wall.mcm[q].shortest;
  ASSERT_LT(ci.low, 0.99999999996);  // the interval crosses the limit
  EXPECT_EQ(wall.conformity[q]->verdict, "undetermined");
  std::string statement;
  for (const auto& s : results_internal::ResultStatements(r))
    statement = s.quantity == "normal_x" ? s.text : statement;
  EXPECT_EQ(statement.rfind("Monte Carlo 95 % shortest coverage interval [", 0), 0u) << statement;
  EXPECT_NE(statement.find("undetermined against ≥ 0.99999999996 (ISO 14253-1 with the Monte Carlo"),
            std::string::npos)
      << statement;
  options.monte_carlo = false;
  for (const auto& s : results_internal::ResultStatements(RunJob(job, options))) {
    if (s.quantity == "normal_x") {
      EXPECT_EQ(s.text.find("exact"), std::string::npos) << s.text;
      EXPECT_NE(s.text.find("U 0 to first order"), std::string::npos) << s.text;
    }
  }
}

}  // namespace
}  // namespace vlt
