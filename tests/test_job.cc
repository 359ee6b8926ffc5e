// test_job.cc — the job file parser (runtime/src/job*.cc, docs/job-file.md): units in every kind
// of key against their definitions, defaults from the model metadata, correlation matrices,
// readings CSVs (units, zenith angles, faces), map grids, CSV parsing, and every class of bad
// input with its one-line message. (The same classes through the `vlt` binary, with the check
// that no output file is written: tests/cli.cmake.)
#include "vlt/job.h"

#include <cmath>
#include <exception>
#include <functional>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "base/csv.h"
#include "base/section.h"
#include "base/time.h"
#include "vlt/error.h"
#include "vlt/models.h"

namespace vlt {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kArcsec = kPi / (180.0 * 3600.0);

const std::string kTracker = R"(
[tracker]
model = "mirror"
[tracker.noise]
range = "5 um + 0.5 um/m"
azimuth = "0.5 arcsec"
elevation = "0.5 arcsec"
)";
const std::string kPlan = R"(
[plan]
unit = "mm"
point = [ {name = "A", x = 3000, y = 0, z = 0}, {name = "B", x = 4000, y = 1000, z = 0},
          {name = "C", x = 3000, y = 1000, z = 500} ]
)";

Job Parse(const std::string& text) {
  return ParseJob(text, "job.toml", std::filesystem::temp_directory_path());
}

// The InputError message of parsing `text`, or "" when it parses.
std::string ErrorOf(const std::string& text,
                    const std::filesystem::path& base = std::filesystem::temp_directory_path()) {
  try {
    ParseJob(text, "job.toml", base);
  } catch (const InputError& e) {
    std::string message = e.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << "message must be one line: " << message;
    return message;
  }
  return "";
}

const UncertainInput& Param(const Job& job, const char* name) {
  int k = FindParam(*job.setup.model, name);
  EXPECT_GE(k, 0) << name;
  return job.setup.params.at(static_cast<std::size_t>(k));
}

TEST(Job, MinimalJobAndModelDefaults) {
  Job job = Parse(kTracker + kPlan);
  ASSERT_NE(job.setup.model, nullptr);
  EXPECT_STREQ(job.setup.model->name, "mirror");
  EXPECT_EQ(job.name, "job");  // the file's stem
  EXPECT_EQ(job.mode, JobMode::kPlan);
  ASSERT_EQ(job.points.size(), 3u);
  // Bare numbers are in plan.unit (mm).
  EXPECT_DOUBLE_EQ(job.points[1].nominal.x(), 4.0);
  EXPECT_DOUBLE_EQ(job.points[2].nominal.z(), 0.5);
  // Omitted parameters: estimate, u, distribution from the model's metadata.
  ASSERT_EQ(job.setup.params.size(), static_cast<std::size_t>(job.setup.model->num_params));
  for (int k = 0; k < job.setup.model->num_params; ++k) {
    const QuantityInfo& q = job.setup.model->params[k];
    EXPECT_EQ(job.setup.params[k].name, q.name);
    EXPECT_DOUBLE_EQ(job.setup.params[k].u, q.default_u) << q.name;
    EXPECT_DOUBLE_EQ(job.setup.params[k].estimate, q.default_estimate) << q.name;
  }
  EXPECT_TRUE(job.setup.correlations.empty());
  EXPECT_FALSE(job.setup.environment.has_value());
  EXPECT_FALSE(job.setup.pose.has_value());
  EXPECT_FALSE(job.setup.thermal.has_value());
  // Monte Carlo defaults (docs/job-file.md).
  EXPECT_TRUE(job.monte_carlo.enabled);
  EXPECT_EQ(job.monte_carlo.trials, 200000);
  EXPECT_DOUBLE_EQ(job.monte_carlo.coverage_probability, 0.95);
  EXPECT_EQ(job.monte_carlo.n_dig, 2);
}

// The job's record (vlt/job_record.h): read as given, empty when absent; a control character in a
// text is one line naming the key (it is printed in headers); an unknown key of [job.instrument]
// names the ones there are.
TEST(Job, RecordOfTheJob) {
  const std::string record = R"(
[job]
name = "bracket"
customer = "ACME Aero"
operator = "J. Smith"
place = "Hall 3"
conditions = "20.5 +- 0.5 degC"
[job.instrument]
make = "Leica"
model = "AT960-MR"
serial = "391234"
)";
  const Job job = Parse(record + kTracker + kPlan);
  EXPECT_EQ(job.record.customer, "ACME Aero");
  EXPECT_EQ(job.record.operator_name, "J. Smith");
  EXPECT_EQ(job.record.place, "Hall 3");
  EXPECT_EQ(job.record.conditions, "20.5 +- 0.5 degC");
  EXPECT_EQ(DescribeInstrument(job.record.instrument), "Leica AT960-MR, serial 391234");
  EXPECT_TRUE(Parse(kTracker + kPlan).record.empty());
  InstrumentIdentity serial_only;
  serial_only.serial = "7";
  EXPECT_EQ(DescribeInstrument(serial_only), "serial 7");
  EXPECT_EQ(ErrorOf("[job]\ncustomer = \"A\\nB\"\n" + kTracker + kPlan),
            "job.toml: job.customer: a control character in the text (one line of printable text expected)");
  // C1 (NEL, a line break), a line separator and a bidirectional override are refused too.
  for (const char* text : {"A\xc2\x85"
                           "B",
                           "A\xe2\x80\xa8"
                           "B",
                           "A\xe2\x80\xae"
                           "B",
                           "A\xe2\x81\xa6"
                           "B"}) {
    EXPECT_NE(ErrorOf("[job]\nplace = \"" + std::string(text) + "\"\n" + kTracker + kPlan)
                  .find("job.place: a control character"),
              std::string::npos)
        << text;
  }
  EXPECT_EQ(Parse("[job]\nplace = \"Zürich, 20 °C ± 0.5 K\"\n" + kTracker + kPlan).record.place,
            "Zürich, 20 °C ± 0.5 K");
  const std::string bad_key = ErrorOf("[job.instrument]\nmaker = \"Leica\"\n" + kTracker + kPlan);
  EXPECT_NE(bad_key.find("job.instrument.maker"), std::string::npos) << bad_key;
  EXPECT_NE(bad_key.find("make, model, serial"), std::string::npos) << bad_key;
}

TEST(Job, UnitsInEveryKindOfKey) {
  Job job = Parse(R"(
[job]
name = "units"
[tracker]
model = "mirror"
[tracker.noise]
range = "5 um + 0.5 um/m"
azimuth = "2 urad"
elevation = "0.001 deg"
[tracker.parameters]
tmv = { estimate = "1 um", u = "0.002 mm" }
rmv = { u = "0.8 arcsec", distribution = "rectangular" }
mu = { u = "0.5 ppm" }
sdh = { u = 0 }
thv = "3 um"
[environment]
equation = "edlen"
wavelength = "0.6328 um"
temperature = { estimate = "293.65 K", u = "200 mK" }
pressure = { estimate = "1013.25 hPa", u = "0.3 mbar" }
humidity = { estimate = "45 %", u = "5 %" }
co2 = { estimate = "450 ppm", u = "0.003 %" }
[station]
rz = { estimate = "20 deg", u = "5 urad" }
tx = { estimate = "-2.5 m", u = "15 um" }
[part]
cte = { estimate = "23 ppm/K", u = "1 um/m/K" }
temperature = { estimate = "22.3 degC", u = "0.2 K" }
reference = "20 degC"
)" + kPlan);
  const double um = 1e-6;
  EXPECT_NEAR(job.setup.noise.range_a, 5 * um, 1e-18);
  EXPECT_NEAR(job.setup.noise.range_b, 0.5e-6, 1e-18);
  EXPECT_NEAR(job.setup.noise.azimuth, 2e-6, 1e-18);
  EXPECT_NEAR(job.setup.noise.elevation, 0.001 * kPi / 180, 1e-18);
  EXPECT_NEAR(Param(job, "tmv").estimate, 1 * um, 1e-18);
  EXPECT_NEAR(Param(job, "tmv").u, 2 * um, 1e-18);
  EXPECT_NEAR(Param(job, "rmv").u, 0.8 * kArcsec, 1e-18);
  EXPECT_EQ(Param(job, "rmv").distribution, "rectangular");
  EXPECT_NEAR(Param(job, "mu").u, 0.5e-6, 1e-18);
  EXPECT_EQ(Param(job, "sdh").u, 0.0);                     // u = 0 switches a parameter off
  EXPECT_NEAR(Param(job, "thv").estimate, 3 * um, 1e-18);  // a bare quantity is the estimate
  EXPECT_EQ(Param(job, "thv").u, job.setup.model->params[FindParam(*job.setup.model, "thv")].default_u);
  ASSERT_TRUE(job.setup.environment.has_value());
  const Environment& env = *job.setup.environment;
  EXPECT_EQ(env.equation, Environment::Equation::kEdlenBoensch);
  EXPECT_NEAR(env.vacuum_wavelength, 632.8e-9, 1e-18);
  EXPECT_NEAR(env.temperature.estimate, 20.5, 1e-12);  // 293.65 K = 20.5 degC
  EXPECT_NEAR(env.temperature.u, 0.2, 1e-15);
  EXPECT_NEAR(env.pressure.estimate, 101325.0, 1e-9);
  EXPECT_NEAR(env.pressure.u, 30.0, 1e-12);
  EXPECT_NEAR(env.humidity.estimate, 45.0, 1e-12);
  EXPECT_NEAR(env.co2.estimate, 450e-6, 1e-18);
  EXPECT_NEAR(env.co2.u, 30e-6, 1e-18);
  ASSERT_TRUE(job.setup.pose.has_value());
  EXPECT_NEAR(job.setup.pose->rz.estimate, 20 * kPi / 180, 1e-15);
  EXPECT_NEAR(job.setup.pose->rz.u, 5e-6, 1e-18);
  EXPECT_NEAR(job.setup.pose->tx.estimate, -2.5, 1e-15);
  EXPECT_EQ(job.setup.pose->rx.u, 0.0);  // omitted pose inputs: 0 +- 0
  ASSERT_TRUE(job.setup.thermal.has_value());
  EXPECT_NEAR(job.setup.thermal->cte.estimate, 23e-6, 1e-18);
  EXPECT_NEAR(job.setup.thermal->cte.u, 1e-6, 1e-18);
  EXPECT_NEAR(job.setup.thermal->temperature.estimate, 22.3, 1e-12);
  EXPECT_EQ(job.name, "units");
}

TEST(Job, EnvironmentEquationSpellings) {
  const auto job_with = [](const std::string& equation, const std::string& extra = "") {
    return kTracker + "[environment]\nequation = \"" + equation + "\"\n" + extra +
           "temperature = \"20 degC\"\npressure = \"1013.25 hPa\"\nhumidity = \"50 %\"\n" + kPlan;
  };
  // NIST's modified Edlén (Birch-Downs): "modified_edlen" and its aliases; "edlen" stays
  // Bönsch-Potulski (docs/job-file.md).
  for (const char* spelling : {"modified_edlen", "birch_downs", "edlen_birch_downs"}) {
    Job job = Parse(job_with(spelling));
    ASSERT_TRUE(job.setup.environment.has_value()) << spelling;
    EXPECT_EQ(job.setup.environment->equation, AirEquation::kEdlenBirchDowns) << spelling;
    EXPECT_EQ(EquationOf(*job.setup.environment), AirEquation::kEdlenBirchDowns) << spelling;
  }
  EXPECT_EQ(Parse(job_with("edlen")).setup.environment->equation, AirEquation::kEdlenBoensch);
  EXPECT_EQ(Parse(job_with("ciddor")).setup.environment->equation, AirEquation::kCiddor);
  // A bad spelling: the one-line message names every accepted spelling.
  EXPECT_EQ(
      ErrorOf(job_with("edlen-modified")),
      "job.toml: environment.equation: unknown refractive-index equation 'edlen-modified' (expected one "
      "of: ciddor, edlen, edlen_boensch, boensch_potulski, modified_edlen, birch_downs, edlen_birch_downs)");
  // Its range of validity (350 .. 650 nm) is checked — outside it n is computed with a warning
  // (issue 36; an error under --strict) —; CO2 is not an input of it, so a CO2 estimate the other
  // equations warn about is no warning (docs/units.md).
  const auto warnings_of = [&](const std::string& text) {
    std::string all;
    for (const std::string& w : Parse(text).warnings) all += w + "\n";
    return all;
  };
  EXPECT_EQ(ErrorOf(job_with("modified_edlen", "wavelength = \"1550 nm\"\n")), "");
  EXPECT_NE(warnings_of(job_with("modified_edlen", "wavelength = \"1550 nm\"\n"))
                .find("outside the range of validity of the modified Edlen (NIST, Birch-Downs) equation"),
            std::string::npos);
  EXPECT_EQ(warnings_of(job_with("modified_edlen", "co2 = \"3000 ppm\"\n")), "");
  EXPECT_NE(warnings_of(job_with("ciddor", "co2 = \"3000 ppm\"\n")).find("CO2 mole fraction 3000 umol/mol is outside"),
            std::string::npos);
}

TEST(Job, RangeNoiseSpellings) {
  std::string text = kTracker;
  text.replace(text.find("range = \"5 um + 0.5 um/m\""), 25, "range_a = \"0.004 mm\"\nrange_b = \"2 ppm\"");
  Job job = Parse(text + kPlan);
  EXPECT_NEAR(job.setup.noise.range_a, 4e-6, 1e-18);
  EXPECT_NEAR(job.setup.noise.range_b, 2e-6, 1e-18);
  std::string text2 = kTracker;
  text2.replace(text2.find("\"5 um + 0.5 um/m\""), 17, "\"0.3 um/m + 1e+0 um\"");  // either order
  Job job2 = Parse(text2 + kPlan);
  EXPECT_NEAR(job2.setup.noise.range_a, 1e-6, 1e-18);
  EXPECT_NEAR(job2.setup.noise.range_b, 0.3e-6, 1e-18);
}

TEST(Job, CorrelationMatrixPlacedAtTheParameters) {
  Job job = Parse(kTracker + R"(
[tracker.correlations.encoder]
parameters = ["eas", "a0"]
matrix = [[1, 0.4], [0.4, 1]]
)" + kPlan);
  ASSERT_EQ(job.setup.correlations.size(), 1u);
  EXPECT_EQ(job.setup.correlations[0].name, "encoder");
  const MeasurementModel model(job.setup);
  const Eigen::MatrixXd& r = model.shared_correlation();
  ASSERT_EQ(r.rows(), model.num_shared());
  int a0 = FindParam(*job.setup.model, "a0"), eas = FindParam(*job.setup.model, "eas");
  int tmv = FindParam(*job.setup.model, "tmv");
  EXPECT_DOUBLE_EQ(r(a0, eas), 0.4);
  EXPECT_DOUBLE_EQ(r(eas, a0), 0.4);
  EXPECT_DOUBLE_EQ(r(a0, a0), 1.0);
  EXPECT_DOUBLE_EQ(r(a0, tmv), 0.0);
}

// [correlations.<group>]: any shared inputs, by the names results.json prints; with
// [tracker.correlations] one set of groups, assembled by SharedCorrelation.
const std::string kSurroundings = R"(
[environment]
temperature = { estimate = "21 degC", u = "0.3 K" }
pressure = "1010 hPa"
humidity = "40 %"
[station]
rx = "0.001 rad"
tx = { estimate = "1 m", u = "20 um" }
[part]
cte = { estimate = "11.5 ppm/K", u = "1 ppm/K" }
temperature = { estimate = "21.5 degC", u = "0.3 K" }
)";

TEST(Job, CorrelationsBetweenAnyInputs) {
  Job job = Parse(kTracker + R"(
[tracker.correlations.encoder]
parameters = ["eas", "a0"]
matrix = [[1, 0.4], [0.4, 1]]
)" + kSurroundings +
                  R"(
[correlations.thermometer]
inputs = ["environment.temperature", "thermal.temperature", "tmv"]
matrix = [[1, 1, 0.2], [1, 1, 0.2], [0.2, 0.2, 1]]
[correlations.fixture]
inputs = ["pose.rx", "pose.tx", "thermal.cte"]   # pose.rx has u = 0: allowed
matrix = [[1, -0.5, 0], [-0.5, 1, 0.3], [0, 0.3, 1]]
)" + kPlan);
  // The tracker's groups first, then [correlations] in key order.
  ASSERT_EQ(job.setup.correlations.size(), 3u);
  EXPECT_EQ(job.setup.correlations[0].name, "encoder");
  EXPECT_EQ(job.setup.correlations[1].name, "fixture");
  EXPECT_EQ(job.setup.correlations[2].name, "thermometer");
  EXPECT_EQ(job.setup.correlations[2].where_matrix, "job.toml: correlations.thermometer.matrix");
  const MeasurementModel model(job.setup);
  const Eigen::MatrixXd& r = model.shared_correlation();
  auto at = [&](const char* name) {
    for (int s = 0; s < model.num_shared(); ++s) {
      if (model.shared_inputs()[s].name == name) return s;
    }
    ADD_FAILURE() << name;
    return 0;
  };
  EXPECT_DOUBLE_EQ(r(at("a0"), at("eas")), 0.4);
  EXPECT_DOUBLE_EQ(r(at("environment.temperature"), at("thermal.temperature")), 1.0);
  EXPECT_DOUBLE_EQ(r(at("thermal.temperature"), at("tmv")), 0.2);
  EXPECT_DOUBLE_EQ(r(at("tmv"), at("environment.temperature")), 0.2);
  EXPECT_DOUBLE_EQ(r(at("pose.tx"), at("pose.rx")), -0.5);
  EXPECT_DOUBLE_EQ(r(at("thermal.cte"), at("pose.tx")), 0.3);
  EXPECT_DOUBLE_EQ(r(at("thermal.cte"), at("thermal.temperature")), 0.0);
  EXPECT_DOUBLE_EQ(r(at("environment.pressure"), at("environment.temperature")), 0.0);
  EXPECT_TRUE(r.isApprox(r.transpose(), 0.0));
  int correlated = 0;  // off-diagonal non-zeros: 2 (encoder) + 6 (thermometer) + 4 (fixture)
  for (int i = 0; i < r.rows(); ++i)
    for (int j = 0; j < r.cols(); ++j) correlated += i != j && r(i, j) != 0.0;
  EXPECT_EQ(correlated, 12);
}

TEST(Job, CorrelationErrorsAreOneLineNamingFileAndKey) {
  const std::string base = kTracker + kPlan + kSurroundings;
  auto group = [](const std::string& name, const std::string& inputs, const std::string& matrix) {
    return "[correlations." + name + "]\ninputs = [" + inputs + "]\nmatrix = " + matrix + "\n";
  };
  const std::string one = "[[1, 0.5], [0.5, 1]]";
  struct Case {
    std::string text, expected;
  };
  const Case cases[] = {
      // Unknown names: the names of this job are listed.
      {base + group("t", "\"environment.temperature\", \"thermal.temprature\"", one),
       "job.toml: correlations.t.inputs: unknown input 'thermal.temprature' (inputs: a0, eac, "},
      {base + group("t", "\"environment.temperature\", \"thermal.temprature\"", one),
       "environment.temperature, environment.pressure, environment.humidity, environment.co2, pose.rx, "
       "pose.ry, "
       "pose.rz, pose.tx, pose.ty, pose.tz, thermal.cte, thermal.temperature)"},
      // The job file's section names are not the inputs' names: say which is meant.
      {base + group("t", "\"environment.temperature\", \"part.temperature\"", one),
       "job.toml: correlations.t.inputs: unknown input 'part.temperature': inputs are named as results.json "
       "and "
       "budget.csv name them, 'thermal.temperature' for [part] temperature"},
      {base + group("t", "\"station.tx\", \"tmv\"", one),
       "job.toml: correlations.t.inputs: unknown input 'station.tx': inputs are named as results.json and "
       "budget.csv "
       "name them, 'pose.tx' for [station] tx"},
      {kTracker + kPlan + group("t", "\"environment.temperature\", \"tmv\"", one),
       "job.toml: correlations.t.inputs: input 'environment.temperature' is not an input of this job: it has "
       "no "
       "[environment] section"},
      // One input in two groups, across the two spellings and within [correlations].
      {base + "[tracker.correlations.a]\nparameters = [\"tmv\", \"a0\"]\nmatrix = " + one + "\n" +
           group("b", "\"environment.temperature\", \"tmv\"", one),
       "job.toml: correlations.b.inputs: input 'tmv' is already in correlation group 'a' (an input may be in "
       "one "
       "group only)"},
      {base + group("a", "\"environment.temperature\", \"thermal.temperature\"", one) +
           group("b", "\"pose.tx\", \"environment.temperature\"", one),
       "job.toml: correlations.b.inputs: input 'environment.temperature' is already in correlation group "
       "'a'"},
      {base + group("a", "\"tmv\", \"tmv\"", one),
       "job.toml: correlations.a.inputs: input 'tmv' appears twice"},
      {base + "[tracker.correlations.g]\nparameters = [\"tmv\", \"a0\"]\nmatrix = " + one + "\n" +
           group("g", "\"environment.temperature\", \"thermal.temperature\"", one),
       "job.toml: correlations.g.inputs: correlation group name 'g' is used twice"},
      // [tracker.correlations] stays restricted to parameters.
      {base + "[tracker.correlations.c]\nparameters = [\"tmv\", \"environment.temperature\"]\nmatrix = " +
           one + "\n",
       "job.toml: tracker.correlations.c.parameters: unknown parameter 'environment.temperature' of model "
       "'mirror'"},
      // The matrix: not positive semi-definite, wrong size, not a correlation matrix.
      {base + group("t", "\"environment.temperature\", \"thermal.temperature\", \"tmv\"",
                    "[[1, 0.9, 0.9], [0.9, 1, -0.9], [0.9, -0.9, 1]]"),
       "job.toml: correlations.t.matrix: correlation matrix is not positive semi-definite (smallest "
       "eigenvalue -0.8)"},
      {base + group("t", "\"environment.temperature\", \"thermal.temperature\", \"tmv\"", one),
       "job.toml: correlations.t.matrix: expected 3 rows of 3 numbers (one per name in inputs)"},
      {base + group("t", "\"environment.temperature\", \"thermal.temperature\"", "[[1, 0.5], [0.5]]"),
       "job.toml: correlations.t.matrix: row 2: expected 2 numbers"},
      {base + group("t", "\"environment.temperature\", \"thermal.temperature\"", "[[1, 0.5], [0.4, 1]]"),
       "job.toml: correlations.t.matrix: not symmetric"},
      {base + group("t", "\"environment.temperature\", \"thermal.temperature\"", "[[1, 1.5], [1.5, 1]]"),
       "job.toml: correlations.t.matrix: correlation coefficient outside [-1, 1]"},
      {base + group("t", "\"environment.temperature\", \"thermal.temperature\"", "[[0.9, 0.5], [0.5, 1]]"),
       "job.toml: correlations.t.matrix: diagonal element 1 is not 1"},
      {base + group("t", "", "[]"), "job.toml: correlations.t.inputs: no inputs"},
      {base + "[correlations.t]\ninput = [\"tmv\"]\nmatrix = [[1]]\n",
       "job.toml: correlations.t.inputs: required key is missing"},
      {base + "[correlations.t]\ninputs = [\"tmv\"]\nmatrix = [[1]]\nrho = 1\n",
       "job.toml: correlations.t.rho: unknown key"},
      {base + "[correlations]\nt = 1\n", "job.toml: correlations.t: expected a table"},
  };
  for (const Case& c : cases) {
    const std::string message = ErrorOf(c.text);
    EXPECT_NE(message.find(c.expected), std::string::npos)
        << "expected '" << c.expected << "' in the message, got '" << message << "'";
  }
}

// A calibration file's parameters are the correlation group "calibration": other groups may
// correlate other inputs, not those parameters.
TEST(Job, CorrelationsBesideACalibrationFile) {
  const std::filesystem::path dir = std::filesystem::path(VLT_SOURCE_DIR) / "examples" / "calibration";
  const std::string tracker = R"(
[tracker]
model = "head"
calibration = "calibration.toml"
[tracker.noise]
range = "1 um"
azimuth = "0.1 arcsec"
elevation = "0.1 arcsec"
)";
  const std::string plan = "[plan]\npoint = [{name = \"P\", x = 3.0, y = 1.0, z = 0.0}]\n";
  const Job job =
      ParseJob(tracker + plan + kSurroundings +
                   "[correlations.t]\ninputs = [\"environment.temperature\", \"thermal.temperature\"]\n"
                   "matrix = [[1, 0.9], [0.9, 1]]\n",
               "job.toml", dir);
  ASSERT_EQ(job.setup.correlations.size(), 2u);
  EXPECT_EQ(job.setup.correlations[0].name, "calibration");
  EXPECT_EQ(job.setup.correlations[0].where_inputs, "job.toml: tracker.calibration");
  EXPECT_EQ(job.setup.correlations[1].name, "t");
  EXPECT_NO_THROW(MeasurementModel{job.setup});
  EXPECT_NE(
      ErrorOf(tracker + plan + kSurroundings +
                  "[correlations.t]\ninputs = [\"environment.temperature\", \"ex\"]\nmatrix = [[1, 0.5], "
                  "[0.5, 1]]\n",
              dir)
          .find("job.toml: correlations.t.inputs: input 'ex' is already in correlation group 'calibration'"),
      std::string::npos);
  EXPECT_NE(
      ErrorOf(tracker + plan +
                  "[tracker.correlations.c]\nparameters = [\"ex\", \"by\"]\nmatrix = [[1, 0.5], [0.5, 1]]\n",
              dir)
          .find("job.toml: tracker.correlations.c.parameters: input 'ex' is already in correlation group "
                "'calibration'"),
      std::string::npos);
}

TEST(Job, TasksResolveToPointIndices) {
  Job job = Parse(kTracker + kPlan + R"(
[[task]]
kind = "distance"
name = "AB"
points = ["B", "A"]
[[task]]
kind = "plane"
name = "ABC"
points = ["A", "B", "C"]
)");
  ASSERT_EQ(job.tasks.size(), 2u);
  EXPECT_EQ(job.tasks[0].kind, TaskKind::kDistance);
  EXPECT_EQ(job.task_points[0], (std::vector<int>{1, 0}));
  EXPECT_EQ(job.tasks[1].kind, TaskKind::kPlane);
}

class JobFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("vlt_test_job_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  void Write(const std::string& name, const std::string& text) { std::ofstream(dir_ / name) << text; }
  std::filesystem::path dir_;
};

TEST_F(JobFiles, ReadingsCsvWithUnitsZenithAndFaces) {
  // One point in both faces. Front: range 4000 mm, Hz 30 deg, zenith 80 deg (elevation +10 deg).
  // Back face of the same point: Hz 210 deg, zenith 280 deg (elevation 180 - 10 = 170 deg).
  Write("r.csv", "# exported\nPoint,D,Hz,V,Face\nP_F1,4000,30,80,1\nP_F2,4000,210,280,2\n");
  Write("job.toml", kTracker + R"(
[readings]
csv = "r.csv"
vertical_angle = "zenith"
columns = { name = "Point", range = "D", azimuth = "Hz", elevation = "V", face = "Face" }
units = { range = "mm", azimuth = "deg", elevation = "deg" }
)");
  Job job = LoadJob((dir_ / "job.toml").string());
  EXPECT_EQ(job.mode, JobMode::kReadings);
  ASSERT_EQ(job.points.size(), 2u);
  const double deg = kPi / 180;
  EXPECT_NEAR(job.points[0].readings[0], 4.0, 1e-15);
  EXPECT_NEAR(job.points[0].readings[1], 30 * deg, 1e-15);
  EXPECT_NEAR(job.points[0].readings[2], 10 * deg, 1e-14);
  EXPECT_EQ(job.points[0].face, Face::kFront);
  EXPECT_NEAR(job.points[1].readings[1], 210 * deg, 1e-14);
  EXPECT_NEAR(job.points[1].readings[2], 170 * deg, 1e-14);
  EXPECT_EQ(job.points[1].face, Face::kBack);
  // The ideal point of both faces is the same (docs/conventions.md: A + pi, pi - E).
  auto ideal = [](const Eigen::Vector3d& r) {
    return Eigen::Vector3d(r[0] * std::cos(r[2]) * std::cos(r[1]), r[0] * std::cos(r[2]) * std::sin(r[1]),
                           r[0] * std::sin(r[2]));
  };
  EXPECT_LT((ideal(job.points[0].readings) - ideal(job.points[1].readings)).norm(), 1e-12);
}

// Cartesian readings (x, y, z in the tracker frame, as tracker software exports them) are the
// spherical readings through the ideal conversion: read back exactly, the face from the face column.
TEST_F(JobFiles, CartesianReadingsAreTheSphericalOnes) {
  const double deg = kPi / 180;
  // Front face: 4 m at azimuth 30 deg, elevation 10 deg; 6 m at azimuth 300 deg, elevation -20 deg;
  // the first point again in the back face (azimuth 210 deg, elevation 170 deg).
  const Eigen::Vector3d spherical[3] = {
      {4.0, 30 * deg, 10 * deg}, {6.0, 300 * deg, -20 * deg}, {4.0, 210 * deg, 170 * deg}};
  auto ideal = [](const Eigen::Vector3d& r) {
    return Eigen::Vector3d(r[0] * std::cos(r[2]) * std::cos(r[1]), r[0] * std::cos(r[2]) * std::sin(r[1]),
                           r[0] * std::sin(r[2]));
  };
  std::string csv = "name;X [mm];Y [mm];Z [mm];face\n";
  const char* names[3] = {"Wing::A", "Wing::B", "Wing::A_back"};
  const char* faces[3] = {"front", "front", "back"};
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d x = ideal(spherical[i]) * 1e3;
    char line[256];
    std::snprintf(line, sizeof line, "%s;%.12f;%.12f;%.12f;%s\n", names[i], x[0], x[1], x[2], faces[i]);
    std::string row = line;
    for (char& c : row) c = c == '.' && &c != row.data() ? ',' : c;  // a decimal-comma export
    csv += row;
  }
  Write("xyz.csv", csv);
  Write("job.toml", kTracker + R"(
[readings]
csv = "xyz.csv"
coordinates = "cartesian"
columns = { x = "X [mm]", y = "Y [mm]", z = "Z [mm]" }
units = { x = "mm", y = "mm", z = "mm" }
)");
  Job job = LoadJob((dir_ / "job.toml").string());
  ASSERT_EQ(job.points.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(job.points[i].name, names[i]);
    EXPECT_NEAR(job.points[i].readings[0], spherical[i][0], 1e-12) << i;
    EXPECT_NEAR(job.points[i].readings[1], spherical[i][1], 1e-12) << i;
    EXPECT_NEAR(job.points[i].readings[2], spherical[i][2], 1e-12) << i;
  }
  EXPECT_EQ(job.points[0].face, Face::kFront);
  EXPECT_EQ(job.points[2].face, Face::kBack);
  // vertical_angle belongs to spherical readings; the origin has no direction.
  Write(
      "job2.toml",
      kTracker + "[readings]\ncsv = \"xyz.csv\"\ncoordinates = \"cartesian\"\nvertical_angle = \"zenith\"\n");
  EXPECT_THROW(LoadJob((dir_ / "job2.toml").string()), InputError);
  Write("o.csv", "name,x,y,z\nO,0,0,0\n");
  Write("job3.toml", kTracker + "[readings]\ncsv = \"o.csv\"\ncoordinates = \"cartesian\"\n");
  try {
    LoadJob((dir_ / "job3.toml").string());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(
        std::string(e.what()).find("o.csv: line 2: inverse: point (0, 0, 0) m is at the tracker origin"),
        std::string::npos)
        << e.what();
  }
}

TEST_F(JobFiles, ReadingsFaceColumnMustAgree) {
  Write("r.csv", "name,range,azimuth,elevation,face\nP,4,0.5,0.2,back\n");
  Write("job.toml", kTracker + "[readings]\ncsv = \"r.csv\"\n");
  try {
    LoadJob((dir_ / "job.toml").string());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "r.csv: line 2: face column says back but the vertical angle is a front-face reading"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(JobFiles, PlanCsvRelativeToTheJobFile) {
  Write("plan.csv", "name,x,y,z,face\nA,3000,0,0,front\nB,4000,1000,\"12 mm\",back\n");
  Write("job.toml", kTracker + "[plan]\nunit = \"mm\"\ncsv = \"plan.csv\"\n");
  Job job = LoadJob((dir_ / "job.toml").string());
  ASSERT_EQ(job.points.size(), 2u);
  EXPECT_DOUBLE_EQ(job.points[1].nominal.y(), 1.0);
  EXPECT_DOUBLE_EQ(job.points[1].nominal.z(), 0.012);  // a field with its own unit
  EXPECT_EQ(job.points[1].face, Face::kBack);
}

TEST_F(JobFiles, UnreadableCsvRowNamesFileAndLine) {
  Write("plan.csv", "name,x,y,z\nA,3000,0,0\n\nB,4000,1000\n");
  Write("job.toml", kTracker + "[plan]\ncsv = \"plan.csv\"\n");
  try {
    LoadJob((dir_ / "job.toml").string());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("plan.csv: line 4: 3 fields, the header has 4 (separator ','"),
              std::string::npos)
        << e.what();
  }
}

TEST(Job, BadInputClasses) {
  struct Case {
    std::string text, expected;
  };
  const std::string good = kTracker + kPlan;
  auto with = [&](const std::string& from, const std::string& to) {
    std::string t = good;
    std::size_t at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return t.replace(at, from.size(), to);
  };
  const Case cases[] = {
      {with("azimuth = \"0.5 arcsec\"", "azimuth = \"0.5 arcsec"),
       "job.toml: line 6, column 22: TOML syntax error"},
      {with("azimuth = \"0.5 arcsec\"", "azimuth = \"0.5 arcsec\"\nazimth = 1"),
       "job.toml: tracker.noise.azimth: unknown key"},
      {good + "[monte_carlo]\ntrails = 1000\n", "job.toml: monte_carlo.trails: unknown key"},
      {good + "[extra]\n", "job.toml: extra: unknown key"},
      {with("model = \"mirror\"\n", ""), "job.toml: tracker.model: required key is missing"},
      {with("elevation = \"0.5 arcsec\"\n", ""),
       "job.toml: tracker.noise.elevation: required key is missing"},
      {kTracker, "job.toml: plan: required key is missing"},
      {with("model = \"mirror\"", "model = \"mirror\"\n[tracker.parameters]\nfoo = { u = 1 }"),
       "job.toml: tracker.parameters.foo: unknown parameter 'foo' of model 'mirror'"},
      {with("\"mirror\"", "\"laser9000\""), "job.toml: tracker.model: unknown model 'laser9000'"},
      {with("\"mirror\"", "\"jcgm101_additive\""), "is not a tracker model"},
      {with("azimuth = \"0.5 arcsec\"", "azimuth = \"0.5 mm\""),
       "job.toml: tracker.noise.azimuth: '0.5 mm' is a length, expected an angle"},
      {with("model = \"mirror\"", "model = \"mirror\"\n[tracker.parameters]\ntmv = { u = \"1 arcsec\" }"),
       "job.toml: tracker.parameters.tmv.u: '1 arcsec' is an angle, expected a length"},
      {with("model = \"mirror\"", "model = \"mirror\"\n[tracker.parameters]\ntmv = { u = \"-1 um\" }"),
       "job.toml: tracker.parameters.tmv.u: negative uncertainty"},
      {with("model = \"mirror\"", "model = \"mirror\"\n[tracker.parameters]\ntmv = { u = nan }"),
       "job.toml: tracker.parameters.tmv.u: not a finite number"},
      {with("azimuth = \"0.5 arcsec\"", "azimuth = \"-0.5 arcsec\""),
       "job.toml: tracker.noise.azimuth: negative uncertainty"},
      {with("model = \"mirror\"",
            "model = \"mirror\"\n[tracker.parameters]\ntmv = { u = 1e-6, distribution = \"lorentz\" }"),
       "unknown distribution 'lorentz'"},
      {good + "[tracker.correlations.c]\nparameters = [\"a0\", \"eac\", \"eas\"]\n"
              "matrix = [[1, 0.9, 0.9], [0.9, 1, -0.9], [0.9, -0.9, 1]]\n",
       "job.toml: tracker.correlations.c.matrix: correlation matrix is not positive semi-definite"},
      {good + "[tracker.correlations.c]\nparameters = [\"a0\", \"eac\"]\nmatrix = [[1, 0.5], [0.4, 1]]\n",
       "job.toml: tracker.correlations.c.matrix: not symmetric"},
      {with("{name = \"C\", x = 3000, y = 1000, z = 500}", "{name = \"C\", x = 0, y = 0, z = 500}"),
       "job.toml: plan.point[2]: point 'C' lies on the tracker's vertical axis"},
      {with("{name = \"C\", x = 3000", "{name = \"A\", x = 3000"),
       "job.toml: plan.point[2]: point name 'A' used twice"},
      {good + "[[task]]\nkind = \"plane\"\nname = \"p\"\npoints = [\"A\", \"B\"]\n",
       "plane needs at least 3 points"},
      {good + "[[task]]\nkind = \"distance\"\nname = \"d\"\npoints = [\"A\", \"X\"]\n",
       "point 'X' not measured"},
      {good + "[[task]]\nkind = \"torus\"\nname = \"d\"\npoints = [\"A\", \"B\"]\n",
       "unknown task kind 'torus' (expected distance, plane, sphere, circle, line, two_face, cylinder, cone, flatness, straightness, roundness or cylindricity)"},
      {good + "[monte_carlo]\ntrials = 100\n", "job.toml: monte_carlo.trials: at least 2000 trials"},
      {good + "[monte_carlo]\ncoverage_probability = 1.5\n",
       "monte_carlo.coverage_probability: must be between 0 and 1"},
      {good + "[environment]\ntemperature = \"20 degC\"\npressure = \"1013 hPa\"\n",
       "job.toml: environment.humidity: required key is missing"},
      {good + "[environment]\ntemperature = \"-300 degC\"\npressure = \"1013 hPa\"\nhumidity = \"50 %\"\n",
       "below absolute zero"},
      {good + "[map]\nplane = \"w=0\"\nextent = \"0,1,0,1\"\n", "job.toml: map: plane: expected x=<value>"},
      {good + "[map]\nplane = \"z=0\"\nextent = \"0,1,0\"\n",
       "job.toml: map: extent: expected 4 comma-separated values"},
      {good + "[readings]\ncsv = \"x.csv\"\n",
       "give either [plan] (offline) or [readings] (online), not both"},
      {good + "[output]\ndetail = \"everything\"\n",
       "job.toml: output.detail: must be \"auto\", \"full\" or \"compact\""},
      {good + "[output]\narrays = \"yes\"\n", "job.toml: output.arrays:"},
  };
  for (const Case& c : cases) {
    std::string message = ErrorOf(c.text);
    EXPECT_NE(message.find(c.expected), std::string::npos)
        << "expected '" << c.expected << "' in the message, got '" << message << "'";
  }
}

// The first repeated point name in file order (job/job.cc finds it by sorted hashes, not a set of
// names): random plans of 2 to 40 points named from a small alphabet, against inserting the names
// into a std::set in order; the message names the repeat and where it is.
TEST(Job, TheFirstRepeatedPointNameIsReported) {
  std::mt19937 gen(41);
  int repeats = 0;
  for (int plan = 0; plan < 300; ++plan) {
    const int n = 2 + static_cast<int>(gen() % 39);
    const int alphabet = 2 + static_cast<int>(gen() % 60);
    std::string points;
    std::vector<std::string> names;
    for (int i = 0; i < n; ++i) {
      names.push_back("P" + std::to_string(gen() % static_cast<unsigned>(alphabet)));
      points += (i ? ", " : "") + std::string("{name = \"") + names.back() + "\", x = " +
                std::to_string(3000 + i) + ", y = " + std::to_string(100 + i) + ", z = 0}";
    }
    std::string expected;
    std::set<std::string> seen;
    for (int i = 0; i < n && expected.empty(); ++i) {
      if (!seen.insert(names[i]).second) {
        expected = "job.toml: plan.point[" + std::to_string(i) + "]: point name '" + names[i] + "' used twice";
      }
    }
    repeats += expected.empty() ? 0 : 1;
    const std::string text = kTracker + "[plan]\nunit = \"mm\"\npoint = [ " + points + " ]\n" + kSurroundings;
    EXPECT_EQ(ErrorOf(text), expected) << text;
  }
  EXPECT_GT(repeats, 100);
  EXPECT_LT(repeats, 300);
}

TEST(Job, MapGrid) {
  MapSettings plane = ParseMapPlane("z = -0.8 m", "2.5 m, 7.5, -2m, 2 m", "0.1 m", "cli");
  EXPECT_EQ(plane.fixed_axis, 2);
  EXPECT_DOUBLE_EQ(plane.level, -0.8);
  EXPECT_EQ(plane.counts(), Eigen::Vector3i(51, 41, 1));  // (7.5-2.5)/0.1+1, (2+2)/0.1+1
  std::vector<Eigen::Vector3d> nodes = plane.Nodes();
  ASSERT_EQ(nodes.size(), 51u * 41u);
  EXPECT_NEAR(nodes[1].x(), 2.6, 1e-12);  // x fastest
  EXPECT_NEAR(nodes[51].y(), -1.9, 1e-12);
  EXPECT_DOUBLE_EQ(nodes.back().z(), -0.8);
  MapSettings side = ParseMapPlane("y=1", "0,4,-1,1", "500 mm", "cli");  // free axes x and z
  EXPECT_EQ(side.counts(), Eigen::Vector3i(9, 1, 5));
  MapSettings box = ParseMapBox("0,1,0,1,0,1", "0.5m", "cli");
  EXPECT_EQ(box.counts(), Eigen::Vector3i(3, 3, 3));
  EXPECT_THROW(ParseMapBox("0,1,0,1,0,1", "0 m", "cli"), InputError);
  EXPECT_THROW(ParseMapBox("0,100,0,100,0,100", "0.01 m", "cli"), InputError);  // > 1e6 nodes
}

TEST(Csv, QuotesCommentsAndLineNumbers) {
  base_internal::CsvTable t = base_internal::ParseCsv("\xEF\xBB\xBF# comment\n\nname , x\r\n\"a,b\", 1\n\"say \"\"hi\"\"\",2\n", "f.csv");
  ASSERT_EQ(t.header.size(), 2u);
  EXPECT_EQ(t.header[0], "name");
  EXPECT_EQ(t.header_line, 3);
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_EQ(t.rows[0].fields[0], "a,b");
  EXPECT_EQ(t.rows[0].line, 4);
  EXPECT_EQ(t.rows[1].fields[0], "say \"hi\"");
  EXPECT_EQ(t.Where(t.rows[1]), "f.csv: line 5");
  EXPECT_THROW(base_internal::ParseCsv("a,b\n\"x,1\n", "f.csv"), InputError);
  EXPECT_THROW(base_internal::ParseCsv("a,a\n", "f.csv"), InputError);
  EXPECT_THROW(base_internal::ParseCsv("# only\n", "f.csv"), InputError);
}

// A name is one line of visible text (base/section.h CheckName): a line break, a tab, an escape
// sequence or a bidirectional override in a point's or a task's name is refused at its key (they
// broke the summary's rows and went raw into points.csv); other Unicode is a name like any.
TEST(Job, NamesAreOneLineOfVisibleText) {
  auto plan_with = [](const std::string& name) {
    return kTracker + "[plan]\npoint = [ {name = \"" + name + "\", x = 3, y = 0, z = 0}, {name = \"B\", x = 4, y = 1, z = 0} ]\n";
  };
  const std::string refused = ": the point name holds a control or layout character";
  EXPECT_EQ(ErrorOf(plan_with("A\\u001b[31mRED")), "job.toml: plan.point[0].name" + refused +
                                                       " (a line break, tab, escape or bidirectional mark): a name is one "
                                                       "line of visible text");
  EXPECT_NE(ErrorOf(plan_with("A\\tB")).find("plan.point[0].name" + refused), std::string::npos);
  EXPECT_NE(ErrorOf(plan_with("A\\u202eB")).find("plan.point[0].name" + refused), std::string::npos);  // RLO
  EXPECT_NE(ErrorOf(plan_with("A\\u0085B")).find("plan.point[0].name" + refused), std::string::npos);  // NEL
  EXPECT_EQ(ErrorOf(plan_with("")), "job.toml: plan.point[0].name: empty point name");
  EXPECT_EQ(ErrorOf(plan_with("Ø 12 – Bohrung ≤ 5 µm")), "");
  const std::string task = "[[task]]\nkind = \"distance\"\nname = \"line1\\nline2\"\npoints = [\"A\", \"B\"]\n";
  EXPECT_NE(ErrorOf(plan_with("A") + task).find("task[0].name: the task name holds a control or layout character"),
            std::string::npos);
  // From a plan CSV (the file a scan's 10^6 names come from).
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "vlt_test_names";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "plan.csv") << "name,x,y,z\nA,3,0,0\nB\x1b]0;title\x07,4,1,0\n";
  EXPECT_EQ(ErrorOf(kTracker + "[plan]\ncsv = \"plan.csv\"\n", dir),
            (dir / "plan.csv").string() + ": line 3" + refused +
                " (a line break, tab, escape or bidirectional mark): a name is one line of visible text");
  std::filesystem::remove_all(dir);
}

// A header's first repeated column, in the header's order, also in a header of 2 * 10^5 columns
// (found by a set: a pairwise comparison took 18 s at 10^5 columns and hung at 10^6).
TEST(Csv, AWideHeaderSaysItsFirstRepeatedColumn) {
  std::string header = "name,x,y,z";
  for (int i = 0; i < 200'000; ++i) header += ",c" + std::to_string(i);
  EXPECT_EQ(base_internal::ParseCsv(header + "\n", "f.csv").header.size(), 200'004u);
  try {
    base_internal::ParseCsv(header + ",c7,x,c3\n", "f.csv");
    ADD_FAILURE() << "a repeated column was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "f.csv: line 1: column 'c7' appears twice");
  }
}

// What vlt checks before toml++ parses (base/section.h ParseToml): a dotted key or table name of
// more than 64 parts is one error line, not a crash (toml++ 3.3.0 recursed per part and overflowed
// the stack at some 40 000); dots in values (numbers, times, strings) are not parts; a UTF-8 byte
// order mark at the start is skipped.
TEST(Toml, DottedKeysOfTooManyPartsAreRefusedNotACrash) {
  auto parts = [](int n, const std::string& part) {
    std::string key = part;
    for (int i = 1; i < n; ++i) key += " . " + part;
    return key;
  };
  auto refused = [](const std::string& text) {
    try {
      base_internal::ParseToml(text, "job.toml");
    } catch (const InputError& e) {
      return std::string(e.what()).find("job.toml: line ") == 0 &&
             std::string(e.what()).find("of more than 64 parts") != std::string::npos;
    }
    return false;
  };
  EXPECT_EQ(base_internal::ParseToml(parts(64, "a") + " = 1\n", "job.toml").size(), 1u);
  EXPECT_TRUE(refused(parts(65, "a") + " = 1\n"));
  EXPECT_TRUE(refused(parts(65, "\"a\"") + " = 1\n"));       // quoted parts
  EXPECT_TRUE(refused("[" + parts(65, "t") + "]\nx = 1\n"));  // a table name
  EXPECT_TRUE(refused("x = 1\n" + parts(50'000, "a") + " = 1\n"));
  const std::string dots_in_values = "x = 1.5\ny = \"" + parts(100, "a") + "\"\nz = 1979-05-27T07:32:00.999\n" +
                                     "w = [1.5, 2.5, 3.5]\nv = { " + parts(64, "b") + " = 0.5 }\n";
  EXPECT_EQ(base_internal::ParseToml(dots_in_values, "job.toml").size(), 5u);
  EXPECT_EQ(base_internal::ParseToml("\xEF\xBB\xBFx = 1\n", "job.toml").size(), 1u);
}

// A text of many pieces (issue 33: a scan's plan is parsed piece by piece side by side): every
// row with its own fields and line number, whatever the line ends (LF, CRLF, a lone CR), blank and
// comment lines, quotes and decimal commas; the same table when the pieces run in reverse order;
// the first wrong row of the file is the one said, also when a later piece fails too.
TEST(Csv, ManyPiecesGiveEveryRowWithItsLine) {
  std::mt19937_64 rng(33);
  const char* const ends[] = {"\n", "\r\n", "\r"};
  struct Expected {
    int line;
    std::string name, x;
  };
  auto make = [&](char separator, std::vector<Expected>& expected, int bad_at, int second_bad_at) {
    std::string text = "# plan\r\n\nname" + std::string(1, separator) + "x\n";
    int line = 4;
    for (int i = 0; i < 60000; ++i, ++line) {
      const std::uint64_t r = rng();
      if (r % 17 == 0) {
        text += r % 2 ? "# comment" : "  ";
      } else if (i == bad_at || i == second_bad_at) {
        text += "P" + std::to_string(i);  // one field of two
      } else {
        const bool quoted = r % 5 == 0;
        const std::string name = quoted ? "Q \"" + std::to_string(i) + "\"" : "P" + std::to_string(i);
        const std::string x = std::to_string(i % 1000) + (separator == ';' ? "," : ".") + std::to_string(r % 97);
        text += quoted ? "\"Q \"\"" + std::to_string(i) + "\"\"\"" : name;
        text += separator;
        text += " " + x + " ";
        expected.push_back({line, name, separator == ';' ? std::to_string(i % 1000) + "." + std::to_string(r % 97) : x});
      }
      text += ends[(r >> 8) % (separator == ';' ? 2 : 3)];
    }
    return text;
  };
  auto reverse = [](std::size_t count, const std::function<void(std::size_t)>& task) {
    std::exception_ptr first;
    for (std::size_t k = count; k-- > 0;) {
      try {
        task(k);
      } catch (...) {
        first = std::current_exception();
      }
    }
    if (first) std::rethrow_exception(first);
  };
  for (const char separator : {',', ';'}) {
    std::vector<Expected> expected, unused;
    const std::string text = make(separator, expected, -1, -1);
    ASSERT_GT(text.size(), 3u << 18);  // several pieces of 256 KiB
    for (int order = 0; order < 2; ++order) {
      const base_internal::CsvTable t =
          order == 0 ? base_internal::ParseCsv(text, "f.csv") : base_internal::ParseCsv(text, "f.csv", nullptr, reverse);
      ASSERT_EQ(t.rows.size(), expected.size());
      for (std::size_t i = 0; i < expected.size(); ++i) {
        ASSERT_EQ(t.rows[i].line, expected[i].line) << i;
        ASSERT_EQ(t.rows[i].fields[0], expected[i].name) << i;
        ASSERT_EQ(t.rows[i].fields[1], expected[i].x) << i;
      }
    }
    // Rows 41000 and 59000 are wrong (in later pieces): the message names the first one's line.
    const std::string bad = make(separator, unused, 41000, 59000);
    for (int order = 0; order < 2; ++order) {
      try {
        order == 0 ? base_internal::ParseCsv(bad, "f.csv") : base_internal::ParseCsv(bad, "f.csv", nullptr, reverse);
        FAIL();
      } catch (const InputError& e) {
        const std::string said = "f.csv: line " + std::to_string(41000 + 4) + ": 1 fields, the header has 2";
        EXPECT_EQ(std::string(e.what()).substr(0, said.size()), said);
      }
    }
  }
}

// Lines longer than the windows a line's end is searched in (512 bytes, doubling), and a file of
// lone CRs only (no LF: a search for an LF to the end of the text per line was quadratic in the
// file's size): every row with its fields and line number.
TEST(Csv, LongLinesAndLoneCarriageReturns) {
  std::mt19937_64 rng(34);
  for (const bool lone_cr_only : {false, true}) {
    std::string text = "name,x";
    text += lone_cr_only ? "\r" : "\n";
    std::vector<std::string> names;
    for (int i = 0; i < 20000; ++i) {
      const std::uint64_t r = rng();
      std::string name = "P" + std::to_string(i);
      if (r % 50 == 0) name += std::string(500 + r % 5000, 'a' + static_cast<char>(r % 26));
      names.push_back(name);
      text += name + "," + std::to_string(i);
      text += lone_cr_only ? "\r" : (r >> 8) % 3 == 0 ? "\r" : (r >> 8) % 3 == 1 ? "\r\n" : "\n";
    }
    const base_internal::CsvTable t = base_internal::ParseCsv(text, "f.csv");
    ASSERT_EQ(t.rows.size(), names.size()) << lone_cr_only;
    for (std::size_t i = 0; i < names.size(); ++i) {
      ASSERT_EQ(t.rows[i].line, static_cast<int>(i) + 2) << i;
      ASSERT_EQ(t.rows[i].fields[0], names[i]) << i;
      ASSERT_EQ(t.rows[i].fields[1], std::to_string(i)) << i;
    }
  }
}

// Spreadsheet exports in locales with a decimal comma: ';' separators (or tabs), numbers such as
// "4000,5" and "-0,25e-3" and "12,5 mm" read with a decimal point; a name with a comma stays.
TEST(Csv, SemicolonsAndDecimalCommasAreDetected) {
  base_internal::CsvTable t = base_internal::ParseCsv("name;x;y;z\nWing::Skin::A,1;4000,5;-0,25e-3;12,5 mm\n\"B;1\";1;2;3\n", "f.csv");
  EXPECT_EQ(t.delimiter, ';');
  ASSERT_EQ(t.header.size(), 4u);
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_EQ(t.rows[0].fields[0], "Wing::Skin::A,1");  // not a number: kept
  EXPECT_EQ(t.rows[0].fields[1], "4000.5");
  EXPECT_EQ(t.rows[0].fields[2], "-0.25e-3");
  EXPECT_EQ(t.rows[0].fields[3], "12.5 mm");
  EXPECT_EQ(t.rows[1].fields[0], "B;1");
  base_internal::CsvTable tabs = base_internal::ParseCsv("name\tx\nA\t3,25\n", "t.csv");
  EXPECT_EQ(tabs.delimiter, '\t');
  EXPECT_EQ(tabs.rows[0].fields[1], "3.25");
  // With ',' separators nothing is rewritten, and a wrong row says which separator was used.
  base_internal::CsvTable commas = base_internal::ParseCsv("name,x\n\"3,25\",1\n", "c.csv");
  EXPECT_EQ(commas.rows[0].fields[0], "3,25");
  try {
    base_internal::ParseCsv("name;x;y\nA;1\n", "s.csv");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "s.csv: line 2: 2 fields, the header has 3 (separator ';', taken from the header line)");
  }
}

// A scan's plan is read in pieces side by side (issue 33): the same points for 1, 2 and 3
// threads, and the first wrong row of the file is the one said, whether its value or its fields
// are wrong: a wrong value before a short row in a later piece or the next line, a short row
// before a wrong value.
TEST_F(JobFiles, APlanOfManyPiecesIsTheSameOnAnyThreadCount) {
  auto plan = [](int bad_value_at, int short_row_at) {
    std::string text = "name,x,y,z\n";
    for (int i = 0; i < 40000; ++i) {
      if (i % 1000 == 7) text += "# a comment\n";
      if (i == short_row_at) {
        text += "S" + std::to_string(i) + ",1,2\n";
        continue;
      }
      text += "P" + std::to_string(i) + "," + (i == bad_value_at ? "abc" : std::to_string(1.0 + i * 1e-4)) + "," +
              std::to_string(-1.0 + i * 2e-5) + ",0.5\n";
    }
    return text;
  };
  const std::string job = kTracker + "[plan]\ncsv = \"plan.csv\"\n";
  Write("job.toml", job);
  Write("plan.csv", plan(-1, -1));
  std::vector<Job> jobs;
  for (const int threads : {1, 2, 3}) {
    JobOverrides overrides;
    overrides.threads = threads;
    jobs.push_back(LoadJob((dir_ / "job.toml").string(), overrides));
  }
  ASSERT_EQ(jobs[0].points.size(), 40000u);
  EXPECT_EQ(jobs[0].points[39999].name, "P39999");
  EXPECT_EQ(jobs[0].points[39999].where, (dir_ / "plan.csv").string() + ": line " + std::to_string(1 + 40 + 40000));
  for (std::size_t j = 1; j < jobs.size(); ++j) {
    ASSERT_EQ(jobs[j].points.size(), jobs[0].points.size());
    for (std::size_t i = 0; i < jobs[0].points.size(); ++i) {
      ASSERT_EQ(jobs[j].points[i].name, jobs[0].points[i].name);
      ASSERT_EQ(jobs[j].points[i].where, jobs[0].points[i].where);
      ASSERT_EQ(jobs[j].points[i].nominal, jobs[0].points[i].nominal);
    }
  }
  // Row 30000 is on line 1 + 30 comments + 30001.
  const std::string at_30000 = (dir_ / "plan.csv").string() + ": line 30032: ";
  const std::string at_20000 = (dir_ / "plan.csv").string() + ": line 20022: ";
  for (const auto& [bad_value_at, short_row_at, said] :
       {std::tuple{30000, 35000, at_30000 + "x"}, std::tuple{35000, 30000, at_30000 + "3 fields"},
        std::tuple{20000, 20001, at_20000 + "x"}}) {
    Write("plan.csv", plan(bad_value_at, short_row_at));
    for (const int threads : {1, 2, 3}) {
      JobOverrides overrides;
      overrides.threads = threads;
      try {
        LoadJob((dir_ / "job.toml").string(), overrides);
        FAIL() << threads;
      } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()).substr(0, said.size()), said) << e.what();
      }
    }
  }
}

// The first repeated name of a large plan (several chunks of 8192 names, 256 buckets searched
// side by side) is the one a set finds inserting the names in order, on any thread count.
TEST_F(JobFiles, TheFirstRepeatedNameOfALargePlanOnAnyThreadCount) {
  std::mt19937 gen(43);
  Write("job.toml", kTracker + "[plan]\ncsv = \"plan.csv\"\n");
  for (int plan = 0; plan < 10; ++plan) {
    const int n = 17000 + static_cast<int>(gen() % 6000);
    std::vector<std::string> names;
    for (int i = 0; i < n; ++i) names.push_back("P" + std::to_string(i));
    // 0 to 4 later points take an earlier point's name (plan 0: none).
    for (int r = 0, repeats = static_cast<int>(gen() % 5); plan > 0 && r < repeats; ++r) {
      const int to = 1 + static_cast<int>(gen() % static_cast<unsigned>(n - 1));
      names[static_cast<std::size_t>(to)] = names[gen() % static_cast<unsigned>(to)];
    }
    std::string text = "name,x,y,z\n";
    for (int i = 0; i < n; ++i) {
      text += names[static_cast<std::size_t>(i)] + "," + std::to_string(1.0 + i * 1e-4) + "," +
              std::to_string(-1.0 + i * 2e-5) + ",0.5\n";
    }
    Write("plan.csv", text);
    std::string expected;
    std::set<std::string> seen;
    for (int i = 0; i < n && expected.empty(); ++i) {
      if (!seen.insert(names[static_cast<std::size_t>(i)]).second) {
        expected = (dir_ / "plan.csv").string() + ": line " + std::to_string(i + 2) + ": point name '" +
                   names[static_cast<std::size_t>(i)] + "' used twice";
      }
    }
    for (const int threads : {1, 2, 3}) {
      JobOverrides overrides;
      overrides.threads = threads;
      std::string said;
      try {
        LoadJob((dir_ / "job.toml").string(), overrides);
      } catch (const InputError& e) {
        said = e.what();
      }
      EXPECT_EQ(said, expected) << "plan " << plan << " on " << threads << " threads";
    }
  }
}

// A plain point list without a header line, fields separated by blanks (issue 36): read when the
// job names its columns, refused with a message that says how otherwise.
TEST_F(JobFiles, PlainPointListWithoutAHeader) {
  Write("list.txt", "# exported from the tracker software\nA   3000.5  0 0\n\"B 2\"\t4000 1000.25   12\n");
  Write("job.toml", kTracker + "[plan]\nunit = \"mm\"\ncsv = \"list.txt\"\nheader = false\n"
                                "columns = [\"name\", \"x\", \"y\", \"z\"]\n");
  Job job = LoadJob((dir_ / "job.toml").string());
  ASSERT_EQ(job.points.size(), 2u);
  EXPECT_EQ(job.points[1].name, "B 2");
  EXPECT_DOUBLE_EQ(job.points[0].nominal.x(), 3.0005);
  EXPECT_DOUBLE_EQ(job.points[1].nominal.y(), 1.00025);
  EXPECT_DOUBLE_EQ(job.points[1].nominal.z(), 0.012);
  EXPECT_EQ(job.points[0].where, (dir_ / "list.txt").string() + ": line 2");
  Write("plain.txt", "A 3000.5 0 0\nB 4000 1000.25 12\n");
  auto message = [&](const std::string& plan) {
    Write("bad.toml", kTracker + "[plan]\ncsv = \"plain.txt\"\n" + plan);
    try {
      LoadJob((dir_ / "bad.toml").string());
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  // With its first line taken for a header the list names no column x: the message says what to write.
  EXPECT_NE(message("").find("header = false and columns = [\"name\", \"x\", \"y\", \"z\"]"), std::string::npos);
  EXPECT_NE(message("header = false\n").find("plan.columns: required key is missing"), std::string::npos);
  EXPECT_NE(message("header = false\ncolumns = [\"name\", \"x\", \"y\"]\n").find("plan.columns: missing column 'z'"),
            std::string::npos);
  EXPECT_NE(message("header = false\ncolumns = [\"name\", \"x\", \"y\", \"w\"]\n").find("unknown column 'w'"),
            std::string::npos);
  EXPECT_NE(message("columns = [\"name\", \"x\", \"y\", \"z\"]\n").find("without a header line (header = false)"),
            std::string::npos);
  // A row with a field too few names the separator taken from the first row.
  Write("short.txt", "A 1 2 3\nB 1 2\n");
  Write("short.toml", kTracker + "[plan]\ncsv = \"short.txt\"\nheader = false\ncolumns = [\"name\", \"x\", \"y\", \"z\"]\n");
  try {
    LoadJob((dir_ / "short.toml").string());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("line 2: 3 fields, the columns name 4 (separator 'blanks', taken from the first row)"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(JobFiles, PlanCsvWithSemicolonsAndDecimalCommas) {
  Write("plan.csv", "name;x;y;z\nA;3000,5;0;0\nB;4000;1000,25;12\n");
  Write("job.toml", kTracker + "[plan]\nunit = \"mm\"\ncsv = \"plan.csv\"\n");
  Job job = LoadJob((dir_ / "job.toml").string());
  ASSERT_EQ(job.points.size(), 2u);
  EXPECT_DOUBLE_EQ(job.points[0].nominal.x(), 3.0005);
  EXPECT_DOUBLE_EQ(job.points[1].nominal.y(), 1.00025);
}

TEST(Job, DefaultJobParses) {
  Job job = ParseJob(DefaultJobToml(), kDefaultJobName, ".");
  EXPECT_EQ(job.name, "vlt-demo");
  EXPECT_EQ(job.mode, JobMode::kPlan);
  EXPECT_GE(job.points.size(), 36u);
  EXPECT_EQ(job.tasks.size(), 4u);
  EXPECT_TRUE(job.map.has_value());
}

// Times of readings (base/time.h): dates against Python's calendar.timegm (an independent count
// of the days since 1970), zones, clock times, quantities; malformed text is an InputError.
TEST(Times, DatesClockTimesAndQuantities) {
  using base_internal::ParseTime;
  EXPECT_DOUBLE_EQ(ParseTime("2026-11-26T10:15:30Z", 1.0, "t").seconds, 1795688130.0);
  EXPECT_EQ(ParseTime("2026-11-26T10:15:30Z", 1.0, "t").kind, TimeKind::kDateTime);
  EXPECT_DOUBLE_EQ(ParseTime("2026-11-26 10:15:30", 1.0, "t").seconds, 1795688130.0);
  EXPECT_DOUBLE_EQ(ParseTime("2026-11-26T10:15:30+01:00", 1.0, "t").seconds, 1795684530.0);
  EXPECT_DOUBLE_EQ(ParseTime("2024-02-29T23:59:59", 1.0, "t").seconds, 1709251199.0);
  EXPECT_DOUBLE_EQ(ParseTime("1970-01-01T00:00:00.25", 1.0, "t").seconds, 0.25);
  EXPECT_DOUBLE_EQ(ParseTime(" 10:15:30.5 ", 1.0, "t").seconds, 36930.5);
  EXPECT_EQ(ParseTime("10:15", 1.0, "t").kind, TimeKind::kClockTime);
  EXPECT_EQ(ParseTime("90 min", 1.0, "t").kind, TimeKind::kSeconds);
  EXPECT_DOUBLE_EQ(ParseTime("10:15", 1.0, "t").seconds, 36900.0);
  EXPECT_DOUBLE_EQ(ParseTime("90 min", 1.0, "t").seconds, 5400.0);
  EXPECT_DOUBLE_EQ(ParseTime("1.5", 3600.0, "t").seconds, 5400.0);
  for (const char* bad : {"2026-02-30T10:00:00", "2026-11-26T25:00:00", "2026-11-26", "10:61", "ten", "1e300",
                          "", "12 um", "2026-11-26T10:15:30+1", "nan"}) {
    EXPECT_THROW(ParseTime(bad, 1.0, "r.csv: line 3: time"), InputError) << bad;
  }
}

}  // namespace
}  // namespace vlt
