// test_shared_settings.cc — the one reader per shared setting (runtime/src/base/shared_settings.h):
// each accepts what it should and refuses the rest with the one message of that mistake, and every
// capability reads the setting through it: a job, a custom job, a network, a calibration and a
// test job all take the coverage probability as 0.95 or "95 %" and refuse 1.5 alike.
#include "base/shared_settings.h"

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "vlt/calibration.h"
#include "vlt/custom_job.h"
#include "vlt/error.h"
#include "vlt/job.h"
#include "vlt/network.h"

namespace vlt {
namespace {

using base_internal::Section;

const std::string kCoverageMessage = ": must be between 0 and 1 (e.g. 0.95 or \"95 %\")";

// The message of reading key `k` of the table `text` (section "s" of "x.toml") with `read`, or ""
// when it reads; `given` is whether the reader reported the key as present.
std::string ErrorOf(const std::string& text, const std::function<bool(Section&)>& read,
                    bool* given = nullptr) {
  const toml::table table = base_internal::ParseToml(text, "x.toml");
  Section s(table, "x.toml", "s");
  try {
    const bool g = read(s);
    if (given) *given = g;
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(SharedSettings, CoverageProbabilityAsANumberOrAPercentage) {
  double p = 0.0;
  auto read = [&](Section& s) { return ReadCoverageProbability(s, "k", p); };
  EXPECT_EQ(ErrorOf("k = 0.99\n", read), "");
  EXPECT_EQ(p, 0.99);
  EXPECT_EQ(ErrorOf("k = \"95 %\"\n", read), "");
  EXPECT_NEAR(p, 0.95, 1e-15);
  bool given = true;
  p = 0.5;
  EXPECT_EQ(ErrorOf("other = 1\n", read, &given), "");
  EXPECT_FALSE(given);
  EXPECT_EQ(p, 0.5);  // absent: the default stays
  for (const char* bad : {"k = 1.5\n", "k = 0\n", "k = 1\n", "k = \"100 %\"\n", "k = -0.1\n"}) {
    EXPECT_EQ(ErrorOf(bad, read), "x.toml: s.k" + kCoverageMessage) << bad;
  }
  EXPECT_NE(ErrorOf("k = \"95 mm\"\n", read).find("x.toml: s.k: "), std::string::npos);
}

// `read` (into `value`) accepts each text of `good` with its value and refuses each text of `bad`
// with its message.
template <typename T>
void ExpectReader(const std::function<bool(Section&)>& read, const T& value,
                  const std::vector<std::pair<std::string, T>>& good,
                  const std::vector<std::pair<std::string, std::string>>& bad) {
  for (const auto& [text, expected] : good) {
    EXPECT_EQ(ErrorOf(text, read), "") << text;
    EXPECT_EQ(value, expected) << text;
  }
  for (const auto& [text, message] : bad) EXPECT_EQ(ErrorOf(text, read), message) << text;
}

TEST(SharedSettings, SeedIsANonNegativeInteger) {
  std::uint64_t seed = 7;
  ExpectReader<std::uint64_t>([&](Section& s) { return ReadSeed(s, "seed", seed); }, seed,
                              {{"seed = 0\n", 0}, {"seed = 2026\n", 2026}, {"other = 1\n", 2026}},
                              {{"seed = -1\n", "x.toml: s.seed: must be a non-negative integer"},
                               {"seed = 1.5\n", "x.toml: s.seed: expected an integer"}});
}

TEST(SharedSettings, TrialsWithinTheCapabilitysLimits) {
  std::int64_t trials = 0;
  ExpectReader<std::int64_t>(
      [&](Section& s) { return ReadTrials(s, "trials", 2, 1000000, " (why)", trials); }, trials,
      {{"trials = 2\n", 2}, {"trials = 1000000\n", 1000000}},
      {{"trials = 1\n", "x.toml: s.trials: at least 2 trials (why)"},
       {"trials = 1000001\n", "x.toml: s.trials: at most 1000000 trials"}});
}

TEST(SharedSettings, ThreadsIterationLimitAndOutlierLimit) {
  int threads = -1, iterations = -1;
  double outlier = 0.0;
  ExpectReader<int>([&](Section& s) { return ReadThreads(s, "threads", threads); }, threads,
                    {{"threads = 0\n", 0}, {"threads = 1024\n", 1024}},
                    {{"threads = 1025\n", "x.toml: s.threads: must be 0 (all) .. 1024"},
                     {"threads = -1\n", "x.toml: s.threads: must be 0 (all) .. 1024"}});
  ExpectReader<int>([&](Section& s) { return ReadIterationLimit(s, "max_iterations", iterations); },
                    iterations, {{"max_iterations = 1\n", 1}, {"max_iterations = 10000\n", 10000}},
                    {{"max_iterations = 0\n", "x.toml: s.max_iterations: must be 1 .. 10000"},
                     {"max_iterations = 10001\n", "x.toml: s.max_iterations: must be 1 .. 10000"}});
  ExpectReader<double>([&](Section& s) { return ReadOutlierLimit(s, "outlier_limit", outlier); }, outlier,
                       {{"outlier_limit = 2.5\n", 2.5}},
                       {{"outlier_limit = 0\n", "x.toml: s.outlier_limit: must be positive"},
                        {"outlier_limit = -3\n", "x.toml: s.outlier_limit: must be positive"}});
}

// The capabilities: an example's file with one line replaced, written beside copies of what it reads.
std::string ExampleText(const std::string& relative) {
  std::ifstream in(std::filesystem::path(VLT_SOURCE_DIR) / "examples" / relative);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string Replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::string WriteJob(const std::string& name, const std::string& text) {
  const std::filesystem::path dir = std::filesystem::path(VLT_BINARY_DIR) / "test-shared-settings";
  std::filesystem::create_directories(dir);
  const std::filesystem::path path = dir / name;
  std::ofstream(path) << text;
  return path.string();
}

// The InputError message of `load`, or "".
std::string Refusal(const std::function<void()>& load) {
  try {
    load();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

const std::string kExamples = std::string(VLT_SOURCE_DIR) + "/examples/";

// A capability's file: an example with `fix` replaced by `fixed` (a path made absolute), whose
// `line` becomes `key_line` + the coverage probability + `after`; `load` gives the probability read.
struct CapabilityFile {
  std::string name, example, fix, fixed, line, key_line, after;
  std::function<double(const std::string&)> load;
  std::string key;  // the message's dotted key
};

// Every capability reads "95 %" as 0.95 and refuses 1.5 with the shared message.
TEST(SharedSettings, EveryCapabilityTakesThePercentage) {
  const std::vector<CapabilityFile> files = {
      {"network", "network/wing_network_plan.toml", "csv = \"wing_targets.csv\"",
       "csv = \"" + kExamples + "network/wing_targets.csv\"", "coverage_probability = 0.95",
       "coverage_probability = ", "",
       [](const std::string& path) { return LoadNetworkJob(path).network.coverage_probability; },
       "network.coverage_probability"},
      {"calibration", "calibration/simulated_calibration.toml", "csv = \"simulated_readings.csv\"",
       "csv = \"" + kExamples + "calibration/simulated_readings.csv\"", "[calibration]\n",
       "[calibration]\ncoverage_probability = ", "\n",
       [](const std::string& path) { return LoadCalibrationJob(path).options.coverage_probability; },
       "calibration.coverage_probability"},
      {"tests", "calibration/head_tracker_tests.toml", "layout = \"../layouts/b89_4_19_2006.toml\"",
       "layout = \"" + kExamples + "layouts/b89_4_19_2006.toml\"", "coverage_probability = 0.95",
       "coverage_probability = ", "",
       [](const std::string& path) { return LoadTestJob(path).settings.coverage_probability; },
       "tests.coverage_probability"},
      {"custom", "custom/jcgm101_additive_rectangular.toml", "[job]", "[job]", "[monte_carlo]\n",
       "[monte_carlo]\ncoverage_probability = ", "\n",
       [](const std::string& path) { return LoadCustomJob(path).monte_carlo.coverage_probability; },
       "monte_carlo.coverage_probability"},
  };
  for (const CapabilityFile& f : files) {
    const std::string text = Replaced(ExampleText(f.example), f.fix, f.fixed);
    auto with = [&](const std::string& p) { return Replaced(text, f.line, f.key_line + p + f.after); };
    const std::string percent = WriteJob(f.name + ".toml", with("\"95 %\""));
    EXPECT_NEAR(f.load(percent), 0.95, 1e-15) << f.name;
    const std::string bad = WriteJob(f.name + "_bad.toml", with("1.5"));
    EXPECT_EQ(Refusal([&] { f.load(bad); }), bad + ": " + f.key + kCoverageMessage);
  }
}

}  // namespace
}  // namespace vlt
