// test_results.cc — Results and the files written from them (docs/results.md): the results.json
// schema keys, CSV headers and units against the GUM values, the map (skipped nodes, never NaN),
// the report page's ingredients, and all-or-nothing writing.
#include "vlt/calibration.h"
#include "vlt/results.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <map>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "base/format.h"
#include "results/internal.h"
#include "vlt/error.h"
#include "vlt/fits.h"
#include "vlt/models.h"
#include "vlt/refractive_index.h"

namespace vlt {
namespace {

const char* kJob = R"(
[job]
name = "results-test"
[tracker]
model = "mirror"
[tracker.noise]
range = "5 um + 0.5 um/m"
azimuth = "0.5 arcsec"
elevation = "0.5 arcsec"
[environment]
temperature = { estimate = "20 degC", u = "0.2 K" }
pressure = { estimate = "1013.25 hPa", u = "0.5 hPa" }
humidity = { estimate = "50 %", u = "5 %" }
[station]
rz = { estimate = "10 deg", u = "5 urad" }
tx = { estimate = "-1 m", u = "10 um" }
[part]
cte = { estimate = "11.5 ppm/K", u = "1 ppm/K" }
temperature = { estimate = "21 degC", u = "0.2 K" }
[plan]
point = [ {name = "A", x = 2, y = 0.5, z = 0}, {name = "B", x = 3, y = 1.5, z = 0.1},
          {name = "C", x = 2.5, y = 1.0, z = 0.6}, {name = "D", x = 4, y = -1, z = -0.3} ]
[[task]]
kind = "distance"
name = "AB"
points = ["A", "B"]
[[task]]
kind = "plane"
name = "ABCD"
points = ["A", "B", "C", "D"]
[monte_carlo]
trials = 4000
seed = 3
n_dig = 1
[map]
plane = "z = 0"
extent = "-1.5, 1.5, -1, 1"
step = "0.5 m"
)";

const Results& SharedResults() {
  static const Results results = [] {
    Job job = ParseJob(kJob, "results.toml", ".");
    RunOptions options;
    options.threads = 2;
    return RunJob(job, options);
  }();
  return results;
}

std::vector<std::string> SplitLine(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string f;
  while (std::getline(ss, f, ',')) out.push_back(f);
  if (!line.empty() && line.back() == ',') out.push_back("");
  return out;
}

// Every input exact (u = 0): the GUM's u and the Monte Carlo spread of each coordinate are
// rounding (the lanes kernel's sine and cosine differ from libm's in the last bit, 2e-16 m here),
// so each point is validated as exact, its coverage region not applicable (both are the point),
// against a resolution of 64 ulps of its size; before, delta = 0 made every point "not validated".
TEST(Results, ExactInputsGiveExactValidatedPoints) {
  std::string params;
  for (const char* p : {"a0", "eac", "eas", "e0", "eec", "ees", "thv", "rhv", "rmv", "tmv", "tbw", "tbv", "rbh",
                        "rbv", "R0", "mu", "srr", "srh", "srv", "sdh"})
    params += std::string(p) + " = { u = 0 }\n";
  Job job = ParseJob(R"([tracker]
model = "mirror"
[tracker.noise]
range = 0
azimuth = 0
elevation = 0
[station]
tx = "-0.8 m"
ty = "-1.0 m"
tz = "1.0 m"
[tracker.parameters]
)" + params + R"([plan]
point = [ {name="A", x=1, y=0, z=0}, {name="B", x=2, y=0.5, z=0}, {name="C", x=1.5, y=1, z=0.1} ]
[monte_carlo]
trials = 2000
seed = 1
)", "exact.toml", ".");
  RunOptions options;
  options.threads = 2;
  const Results r = RunJob(job, options);
  ASSERT_EQ(r.points.size(), 3u);
  for (const PointResult& p : r.points) {
    ASSERT_TRUE(p.has_mcm);
    EXPECT_EQ(p.outcome, "validated") << p.input.name;
    for (int a = 0; a < 3; ++a) {
      EXPECT_TRUE(p.monte_carlo->axis_validation[a].exact) << p.input.name << " axis " << a;
      EXPECT_LE(p.monte_carlo->axis_validation[a].delta, 64 * std::numeric_limits<double>::epsilon() * 4.0);  // ranges < 4 m
    }
    EXPECT_EQ(p.monte_carlo->region_validation.outcome, "not applicable") << p.input.name;
  }
  EXPECT_EQ(r.validated_points, 3);
  // With any spread the points are judged by JCGM 101 8 as before: the shared job's.
  for (const PointResult& p : SharedResults().points) {
    EXPECT_NE(p.monte_carlo->region_validation.outcome, "not applicable") << p.input.name;
  }
}

TEST(Results, JsonSchemaKeys) {
  const Results& r = SharedResults();
  nlohmann::json j = nlohmann::json::parse(ResultsJson(r));
  EXPECT_EQ(j["schema"], "vlt-results/2");
  for (const char* key : {"schema", "vlt_version", "units", "job", "inputs", "monte_carlo", "points_file",
                          "tasks", "map", "summary"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  for (const char* key : {"name", "description", "file", "mode", "model", "coverage_probability", "k_axis",
                          "k_region", "n_dig", "points", "tasks"}) {
    EXPECT_TRUE(j["job"].contains(key)) << "job." << key;
  }
  EXPECT_EQ(j["job"]["mode"], "plan");
  // Provenance: the job file's SHA-256 (of the text it was parsed from), when, which build.
  ASSERT_EQ(j["job"]["input_files"].size(), 1u);
  EXPECT_EQ(j["job"]["input_files"][0]["role"], "job");
  EXPECT_EQ(j["job"]["input_files"][0]["sha256"], Sha256Bytes(kJob));
  EXPECT_EQ(j["vlt_commit"], VltCommit());
  // ISO 8601 UTC, "YYYY-MM-DDThh:mm:ssZ" (no std::regex: GCC 12 warns inside <regex> under -O1 sanitizers).
  const std::string created = j["created"].get<std::string>();
  const std::string shape = "dddd-dd-ddTdd:dd:ddZ";
  ASSERT_EQ(created.size(), shape.size()) << created;
  for (size_t i = 0; i < shape.size(); ++i) {
    if (shape[i] == 'd') {
      EXPECT_TRUE(created[i] >= '0' && created[i] <= '9') << created;
    } else {
      EXPECT_EQ(created[i], shape[i]) << created;
    }
  }
  // Inputs as typed ("0.2 K", "1013.25 hPa", "10 deg"), else in a readable unit (the model's
  // default u of a0 is 0.35 arcsec, its estimate 0).
  auto shared = [&](const std::string& name) {
    for (const auto& in : j["inputs"]["shared"]) {
      if (in["name"] == name) return in;
    }
    return nlohmann::json();
  };
  EXPECT_EQ(shared("environment.temperature")["display_estimate"], "20 degC");
  EXPECT_EQ(shared("environment.temperature")["display_u"], "0.2 K");
  EXPECT_EQ(shared("environment.pressure")["display_estimate"], "1013.25 hPa");
  EXPECT_EQ(shared("pose.rz")["display_estimate"], "10 deg");
  EXPECT_EQ(shared("pose.rz")["display_u"], "5 urad");
  EXPECT_EQ(shared("thermal.cte")["display_u"], "1 ppm/K");
  EXPECT_EQ(shared("a0")["display_u"], "0.35 arcsec");
  EXPECT_EQ(shared("a0")["display_estimate"], "0 arcsec");
  EXPECT_EQ(shared("pose.ty")["display_estimate"], "0 µm");  // not in the job: 0, readable
  for (const char* key : {"noise", "shared", "parameter_correlation", "correlations", "environment_equation",
                          "vacuum_wavelength", "part_reference_temperature"}) {
    EXPECT_TRUE(j["inputs"].contains(key)) << "inputs." << key;
  }
  EXPECT_TRUE(j["inputs"]["parameter_correlation"].is_null());  // independent inputs
  EXPECT_EQ(j["inputs"]["correlations"], nlohmann::json::array());
  // 20 mirror parameters + 4 environment + 6 pose + 2 thermal shared inputs.
  EXPECT_EQ(j["inputs"]["shared"].size(), 32u);
  for (const char* key : {"enabled", "seed", "trials", "adaptive", "converged", "batch_size", "batches",
                          "threads", "seconds", "interval_method", "n_dig"}) {
    EXPECT_TRUE(j["monte_carlo"].contains(key)) << "monte_carlo." << key;
  }
  EXPECT_EQ(j["monte_carlo"]["trials"], 4000);
  // vlt-results/2: no points in results.json; points.jsonl holds one object per point, in job
  // order; the budget rows are in budget.csv only.
  EXPECT_FALSE(j.contains("points"));
  EXPECT_EQ(j["points_file"], "points.jsonl");
  std::stringstream lines(PointsJsonl(r));
  std::vector<nlohmann::json> points;
  for (std::string line; std::getline(lines, line);) points.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(points.size(), 4u);
  EXPECT_EQ(points[3]["name"], r.points[3].input.name);
  const auto& p = points[0];
  for (const char* key : {"name", "face", "readings", "nominal", "gum", "mcm", "validation"}) {
    EXPECT_TRUE(p.contains(key)) << "points[]." << key;
  }
  EXPECT_FALSE(p.contains("budget"));
  for (const char* key : {"estimate", "covariance", "u", "k", "U", "U_norm", "ellipsoid", "line_of_sight",
                          "tracker_frame", "correlation_handling"}) {
    EXPECT_TRUE(p["gum"].contains(key)) << "points[].gum." << key;
  }
  for (const char* key : {"mean", "covariance", "correlation", "has_region", "coverage_factor", "axes"}) {
    EXPECT_TRUE(p["mcm"].contains(key)) << "points[].mcm." << key;
  }
  for (const char* key : {"axes", "region", "validated", "verdict"}) {
    EXPECT_TRUE(p["validation"].contains(key)) << "points[].validation." << key;
  }
  ASSERT_EQ(j["tasks"].size(), 2u);
  for (const char* key : {"name", "kind", "points", "quantities", "units", "gum", "budget_by_group",
                          "budget_by_shared_input", "mcm", "validation"}) {
    EXPECT_TRUE(j["tasks"][0].contains(key)) << "tasks[]." << key;
  }
  for (const char* key : {"kind", "description", "quantity", "fixed_axis", "min", "max", "step", "counts",
                          "coverage_probability", "k", "U_norm", "U_x", "U_y", "U_z", "skipped"}) {
    EXPECT_TRUE(j["map"].contains(key)) << "map." << key;
  }
  // The JSON holds exactly the GUM numbers (SI).
  EXPECT_DOUBLE_EQ(p["gum"]["U"][1].get<double>(), r.points[0].gum.U_part()[1]);
  EXPECT_DOUBLE_EQ(j["tasks"][0]["gum"]["U"][0].get<double>(), r.tasks[0].gum.U[0]);
}

// The one escaping layer of every report's scripts (issue 32): the JSON of a hostile name keeps its
// value but holds no '<', so nothing in it can close or change the <script> element it is in.
TEST(Results, ScriptSafeJsonCannotEndItsScriptElement) {
  const std::string hostile =
      "</script><script>alert(1)</script><!--<script> \u2028 & \"q\" 'a' <img onerror=x>";
  const std::string safe = base_internal::ScriptSafe(nlohmann::json(hostile).dump());
  EXPECT_EQ(safe.find('<'), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(safe).get<std::string>(), hostile);
}

// The report's name in the print design's page-margin box is a CSS string (CSS 2.1 4.1.3): decoded
// by the rules of CSS it is the name again, and it holds no '<' (no "</style>"), no quote but its
// delimiters and no line break.
TEST(Results, CssStringDecodesToTheNameAndCannotEndItsStyle) {
  const std::string hostile = "vlt \"a\" \\ </style><script>x()</script>\n\u202e µm";
  const std::string css = base_internal::CssString(hostile);
  ASSERT_GE(css.size(), 2u);
  ASSERT_EQ(css.front(), '"');
  ASSERT_EQ(css.back(), '"');
  const std::string inner = css.substr(1, css.size() - 2);
  EXPECT_EQ(inner.find('<'), std::string::npos);
  EXPECT_EQ(inner.find('"'), std::string::npos);
  EXPECT_EQ(inner.find('\n'), std::string::npos);
  std::string decoded;
  for (std::size_t i = 0; i < inner.size(); ++i) {
    if (inner[i] != '\\') {
      decoded += inner[i];
      continue;
    }
    std::size_t j = i + 1;
    while (j < inner.size() && j < i + 7 && std::isxdigit(static_cast<unsigned char>(inner[j]))) ++j;
    ASSERT_GT(j, i + 1) << "a non-hex escape";
    decoded += static_cast<char>(std::stoul(inner.substr(i + 1, j - i - 1), nullptr, 16));
    i = (j < inner.size() && inner[j] == ' ') ? j : j - 1;  // one space ends a hex escape
  }
  EXPECT_EQ(decoded, hostile);
}

TEST(Results, ModifiedEdlenNamedInInputsAir) {
  // equation = "modified_edlen" (NIST's modified Edlén, vlt/refractive_index.h) reaches
  // results.json: inputs.environment_equation and inputs.air, whose n_phase is that equation's.
  std::string text = kJob;
  const std::string env = "[environment]\n";
  text.replace(text.find(env), env.size(),
               env + "equation = \"modified_edlen\"\nco2 = { estimate = \"500 ppm\", u = \"50 ppm\" }\n");
  Job job = ParseJob(text, "results.toml", ".");
  RunOptions options;
  options.monte_carlo = false;  // the GUM path is all this needs
  options.compute_map = false;
  options.threads = 1;
  const Results r = RunJob(job, options);
  nlohmann::json j = nlohmann::json::parse(ResultsJson(r));
  EXPECT_EQ(j["inputs"]["environment_equation"], "modified_edlen");
  const auto& air = j["inputs"]["air"];
  EXPECT_EQ(air["equation"], "modified_edlen");
  AirConditions conditions;
  conditions.vacuum_wavelength = 633e-9;
  conditions.temperature = 20.0;
  conditions.pressure = 101325.0;
  conditions.humidity = 50.0;
  conditions.co2 = 500e-6;
  EXPECT_DOUBLE_EQ(air["n_phase"].get<double>(),
                   AirRefractiveIndexValue(AirEquation::kEdlenBirchDowns, conditions));
  EXPECT_GT(air["u_n_phase"].get<double>(), 0.0);
  // CO2 does not enter this equation: its budget rows carry zero sensitivity and contribution.
  bool found = false;
  const std::size_t first[] = {0};
  const std::vector<PointUncertainty> point = PointDetails(r, first, true);
  for (const BudgetRow& row : point.front().budget) {
    if (row.input != "environment.co2") continue;
    found = true;
    EXPECT_EQ(row.sensitivity, Eigen::Vector3d::Zero());
    EXPECT_EQ(row.contribution, Eigen::Vector3d::Zero());
  }
  EXPECT_TRUE(found);
}

// The correlation groups as given, the parameters' block, and the cross terms between groups.
TEST(Results, CorrelationGroupsAreReported) {
  std::string text = kJob;
  text.replace(text.find("[plan]"), 6, R"([tracker.correlations.encoder]
parameters = ["eas", "a0"]
matrix = [[1, 0.4], [0.4, 1]]
[correlations.thermometer]
inputs = ["environment.temperature", "thermal.temperature"]
matrix = [[1, 1], [1, 1]]
[plan])");
  Job job = ParseJob(text, "results.toml", ".");
  RunOptions options;
  options.monte_carlo = false;
  options.compute_map = false;
  options.threads = 1;
  const Results r = RunJob(job, options);
  const nlohmann::json j = nlohmann::json::parse(ResultsJson(r));
  const nlohmann::json& groups = j["inputs"]["correlations"];
  ASSERT_EQ(groups.size(), 2u);
  EXPECT_EQ(groups[0]["name"], "encoder");
  EXPECT_EQ(groups[0]["inputs"], nlohmann::json({"eas", "a0"}));
  EXPECT_EQ(groups[0]["matrix"], nlohmann::json({{1.0, 0.4}, {0.4, 1.0}}));
  EXPECT_EQ(groups[1]["name"], "thermometer");
  EXPECT_EQ(groups[1]["inputs"], nlohmann::json({"environment.temperature", "thermal.temperature"}));
  EXPECT_EQ(groups[1]["matrix"], nlohmann::json({{1.0, 1.0}, {1.0, 1.0}}));
  // The parameters' block of the shared correlation, in the model's parameter order.
  const nlohmann::json& p = j["inputs"]["parameter_correlation"];
  const int a0 = FindParam(*job.setup.model, "a0"), eas = FindParam(*job.setup.model, "eas");
  ASSERT_EQ(p.size(), static_cast<std::size_t>(job.setup.model->num_params));
  EXPECT_EQ(p[a0][eas], 0.4);
  EXPECT_EQ(p[a0][a0], 1.0);
  const std::string handling = r.correlation_handling;
  EXPECT_NE(handling.find("correlation groups: encoder, thermometer"), std::string::npos) << handling;
  // The distance's budget by group: the cross terms between environment and thermal in
  // "correlation"; the entries add up to the variance.
  double sum = 0.0;
  bool cross = false;
  for (const nlohmann::json& g : j["tasks"][0]["budget_by_group"]) {
    sum += g["variance"][0].get<double>();
    cross = cross || g["group"] == "correlation";
  }
  EXPECT_TRUE(cross);
  const double variance = j["tasks"][0]["gum"]["covariance"][0][0];
  EXPECT_NEAR(sum, variance, 1e-9 * variance);
}

TEST(Results, CsvHeadersUnitsAndValues) {
  const Results& r = SharedResults();
  std::stringstream points(PointsCsv(r));
  std::string header, row;
  std::getline(points, header);
  std::vector<std::string> columns = SplitLine(header);
  EXPECT_EQ(columns[0], "name");
  auto column = [&](const std::string& name) {
    auto it = std::find(columns.begin(), columns.end(), name);
    EXPECT_NE(it, columns.end()) << name;
    return static_cast<std::size_t>(it - columns.begin());
  };
  std::getline(points, row);
  std::vector<std::string> fields = SplitLine(row);
  ASSERT_EQ(fields.size(), columns.size());
  // mm and um as the header says.
  EXPECT_NEAR(std::stod(fields[column("x_mm")]), r.points[0].gum.part.x() * 1e3, 1e-9);
  EXPECT_NEAR(std::stod(fields[column("U_y_um")]), r.points[0].gum.U_part().y() * 1e6, 1e-9);
  EXPECT_NEAR(std::stod(fields[column("azimuth_deg")]), r.points[0].gum.readings[1] * 180 / M_PI, 1e-9);
  EXPECT_EQ(fields.back(), r.points[0].outcome);
  // budget.csv: one row per input (3 readings + 32 shared + correlation rows, if any) per point.
  std::stringstream budget(BudgetCsv(r));
  std::getline(budget, header);
  std::size_t n_columns = SplitLine(header).size();
  int rows = 0;
  while (std::getline(budget, row)) {
    EXPECT_EQ(SplitLine(row).size(), n_columns) << row;
    ++rows;
  }
  // The budgets are not held in Results (PointGum has none); budget.csv recomputes them with the
  // run's model and readings: the same numbers as a direct propagation with budgets of the job's
  // points.
  const Job job = ParseJob(kJob, "results.toml", ".");
  const MeasurementModel model(job.setup);
  GumOptions options;
  options.coverage_probability = r.coverage_probability;
  options.threads = 1;
  const std::vector<PointUncertainty> direct = PropagatePoints(model, JobReadings(job, model), options);
  std::size_t expected_rows = 0;
  for (const PointUncertainty& g : direct) expected_rows += g.budget.size();
  EXPECT_EQ(static_cast<std::size_t>(rows), expected_rows);
  EXPECT_GE(direct[0].budget.size(), 35u);
  const std::vector<PointUncertainty> recomputed = PointDetails(r, {}, true);
  ASSERT_EQ(recomputed.size(), direct.size());
  for (std::size_t i = 0; i < recomputed.size(); ++i) {
    const PointUncertainty& g = recomputed[i];
    ASSERT_EQ(g.budget.size(), direct[i].budget.size());
    for (std::size_t b = 0; b < g.budget.size(); ++b) {
      EXPECT_EQ(g.budget[b].input, direct[i].budget[b].input);
      EXPECT_EQ(g.budget[b].sensitivity, direct[i].budget[b].sensitivity);  // bit for bit
      EXPECT_EQ(g.budget[b].contribution, direct[i].budget[b].contribution);
      EXPECT_EQ(g.budget[b].share_total, direct[i].budget[b].share_total);
    }
  }
  // tasks.csv: the distance in mm, its U in um.
  std::stringstream tasks(TasksCsv(r));
  std::getline(tasks, header);
  std::getline(tasks, row);
  fields = SplitLine(row);
  EXPECT_EQ(fields[0], "AB");
  EXPECT_EQ(fields[3], "mm");
  EXPECT_NEAR(std::stod(fields[4]), r.tasks[0].gum.value[0] * 1e3, 1e-9);
  EXPECT_EQ(fields[5], "um");
  EXPECT_NEAR(std::stod(fields[8]), r.tasks[0].gum.U[0] * 1e6, 1e-9);
  // The distance of the nominal points, independently.
  EXPECT_NEAR(r.tasks[0].gum.value[0], std::sqrt(1.0 + 1.0 + 0.01), 1e-9);
}

// A run keeps a PointGum per point; PointDetails gives back the rest. Reference: the GUM engine
// called directly on the job's points (PropagatePoints + CheckSecondOrder), compared bit for bit,
// for every point and for a subset out of order, on 1 and 3 threads.
TEST(Results, PointDetailsAreTheRunsBitForBit) {
  const Results& r = SharedResults();
  const Job job = ParseJob(kJob, "results.toml", ".");
  const MeasurementModel model(job.setup);
  const std::vector<PointReadings> readings = JobReadings(job, model);
  GumOptions options;
  options.coverage_probability = r.coverage_probability;
  options.threads = 1;
  std::vector<PointUncertainty> direct = PropagatePoints(model, readings, options);
  CheckSecondOrder(model, readings, direct, kSecondOrderThreshold, 1);
  ASSERT_EQ(direct.size(), r.points.size());
  auto same = [](const PointUncertainty& a, const PointUncertainty& b) {
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.readings, b.readings);
    EXPECT_EQ(a.part, b.part);
    EXPECT_EQ(a.cov_part, b.cov_part);
    EXPECT_EQ(a.U_part, b.U_part);
    EXPECT_EQ(a.tracker, b.tracker);
    EXPECT_EQ(a.cov_tracker, b.cov_tracker);
    EXPECT_EQ(a.ellipsoid.semi_axes, b.ellipsoid.semi_axes);
    EXPECT_EQ(a.ellipsoid.directions, b.ellipsoid.directions);
    EXPECT_EQ(a.los_part.u_radial, b.los_part.u_radial);
    EXPECT_EQ(a.los_tracker.u_vertical, b.los_tracker.u_vertical);
    EXPECT_EQ(a.second_order_variance, b.second_order_variance);
    EXPECT_EQ(a.second_order_ratio, b.second_order_ratio);
    EXPECT_EQ(a.gum_reliable, b.gum_reliable);
    EXPECT_EQ(a.second_order_decided, b.second_order_decided);
  };
  for (const int threads : {1, 3}) {
    const std::vector<PointUncertainty> all = PointDetails(r, {}, true, threads);
    ASSERT_EQ(all.size(), direct.size());
    for (std::size_t i = 0; i < all.size(); ++i) {
      SCOPED_TRACE(direct[i].name);
      same(all[i], direct[i]);
      EXPECT_EQ(all[i].budget.size(), direct[i].budget.size());
      // What the run kept: the same estimate, covariance and U (the expressions of PropagatePoints).
      EXPECT_EQ(r.points[i].gum.part, direct[i].part);
      EXPECT_EQ(r.points[i].gum.cov_part, direct[i].cov_part);
      EXPECT_EQ(r.points[i].gum.u_part(), direct[i].u_part);
      EXPECT_EQ(r.points[i].gum.U_part(), direct[i].U_part);
      EXPECT_EQ(r.points[i].gum.second_order_ratio, direct[i].second_order_ratio);
    }
  }
  ASSERT_GE(r.points.size(), 3u);
  const std::size_t subset[] = {2, 0, 2};
  const std::vector<PointUncertainty> some = PointDetails(r, subset);
  ASSERT_EQ(some.size(), 3u);
  for (std::size_t n = 0; n < 3; ++n) same(some[n], direct[subset[n]]);
  EXPECT_TRUE(some[0].budget.empty());  // without budgets unless asked
  const std::size_t beyond[] = {r.points.size()};
  EXPECT_THROW(PointDetails(r, beyond), std::out_of_range);
}

TEST(Results, BudgetSensitivitiesInTheUnitsPeopleRead) {
  // budget.csv sensitivity_practical_*: um per um / arcsec / ppm / K / hPa. Independent checks:
  // c_practical times u in the practical unit is the contribution in um; the range reading's
  // sensitivity along the beam is 1 um/um, the azimuth reading's across it rho cos(E) * 4.848
  // um/arcsec (1 arcsec at 1 m), the range scale's rho um/ppm.
  const Results& r = SharedResults();
  std::stringstream budget(BudgetCsv(r));
  std::string header, row;
  std::getline(budget, header);
  const std::vector<std::string> columns = SplitLine(header);
  auto column = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(columns.begin(), columns.end(), name) - columns.begin());
  };
  const std::map<std::string, double> unit_size = {
      {"um/um", 1e-6}, {"um/arcsec", M_PI / 648000}, {"um/ppm", 1e-6}, {"um/K", 1.0}, {"um/hPa", 100.0},
      {"um/%", 1.0},   {"um/(ppm/K)", 1e-6}};
  int checked = 0;
  while (std::getline(budget, row)) {
    const std::vector<std::string> f = SplitLine(row);
    if (f[column("point")] != "A" || f[column("sensitivity_practical_unit")].empty()) continue;
    const std::string unit = f[column("sensitivity_practical_unit")];
    ASSERT_TRUE(unit_size.count(unit)) << unit;
    const double u = std::stod(f[column("u")]) / unit_size.at(unit);  // u in the practical unit
    for (const char* axis : {"x", "y", "z"}) {
      const double c = std::stod(f[column(std::string("sensitivity_practical_") + axis)]);
      const double contribution = std::stod(f[column(std::string("contribution_") + axis + "_um")]);
      EXPECT_NEAR(c * u, contribution, 1e-9 * std::abs(contribution) + 1e-12)
          << f[column("input")] << " " << axis;
    }
    ++checked;
  }
  EXPECT_GE(checked, 30);
  const std::size_t first_point[] = {0};
  const PointUncertainty a = PointDetails(r, first_point, true)[0];
  ASSERT_GE(a.budget.size(), 35u);
  const double rho = a.readings[0], e = a.readings[2];
  for (const BudgetRow& b : a.budget) {
    const auto [unit, factor] = results_internal::PracticalSensitivity(b.input_unit);
    const Eigen::Vector3d c = b.sensitivity * factor;
    if (b.input == "range") {
      EXPECT_EQ(unit, "um/um");
      EXPECT_NEAR(c.norm(), 1.0, 1e-4);  // the range is along the beam; the air scales it by n_est/n ~ 1
    }
    if (b.input == "azimuth") {
      EXPECT_EQ(unit, "um/arcsec");
      EXPECT_NEAR(c.norm(), rho * std::cos(e) * 1e6 * M_PI / 648000, 1e-3 * c.norm());
    }
  }
}

TEST(Results, MapSkipsTheVerticalAxisAndHasNoNaN) {
  const Results& r = SharedResults();
  ASSERT_TRUE(r.map.has_value());
  const MapResult& m = *r.map;
  EXPECT_EQ(m.nodes.size(), 7u * 5u);
  // Station: tracker at part (-1, 0, 0), so the part node (-1, 0, 0) is at the gimbal point.
  ASSERT_EQ(m.skipped.size(), 1u);
  EXPECT_NE(m.skipped[0].find("(-1, 0, 0) m"), std::string::npos) << m.skipped[0];
  for (std::size_t i = 0; i < m.nodes.size(); ++i) {
    EXPECT_TRUE(std::isfinite(m.U_norm[i]));
    if (m.computed[i]) {
      EXPECT_GT(m.U_norm[i], 0.0);
      EXPECT_NEAR(m.U_norm[i], m.U[i].norm(), 1e-18);
    }
  }
  // The tracker (the pose's origin) and the job's points are marked (report maps).
  ASSERT_EQ(m.markers.size(), 1u + 4u);
  EXPECT_EQ(m.markers[0].name, "tracker");
  EXPECT_FALSE(m.markers[0].point);
  EXPECT_NEAR(m.markers[0].position.x(), -1.0 / (1 + 11.5e-6 * (21 - 20)), 1e-12);  // tx, reduced to 20 degC
  EXPECT_EQ(m.markers[1].name, "A");
  EXPECT_TRUE(m.markers[1].point);
  EXPECT_EQ(m.markers[1].position, Eigen::Vector3d(2, 0.5, 0));
  std::string csv = MapCsv(m);
  // No field is a NaN or an infinity ("dominant_source" in the header has "nan" in it).
  for (const char* bad : {",nan", ",-nan", ",inf", ",-inf"})
    EXPECT_EQ(csv.find(bad), std::string::npos) << bad;
  EXPECT_NE(csv.find("skipped: at the tracker's gimbal point"), std::string::npos);
  // A map node where a plan point lies has the same per-axis U as that point (same GUM).
  Job job = ParseJob(kJob, "results.toml", ".");
  MeasurementModel model(job.setup);
  MapSettings at_a = ParseMapPlane("z=0", "2,2,0.5,0.5", "1 m", "test");
  MapResult one = ComputeMap(model, at_a, 0.95, 1);
  ASSERT_EQ(one.nodes.size(), 1u);
  EXPECT_LT((one.U[0] - r.points[0].gum.U_part()).norm(), 1e-12);
}

// SpatialAnalyzer-style names are shown whole in the terminal summary, the columns aligned.
TEST(Results, SummaryShowsLongPointNamesWhole) {
  Results r = SharedResults();
  const std::string name = "Wing::Skin::Collection::Point_0001";
  r.points[0].input.name = name;
  const std::string summary = SummaryText(r);
  const std::size_t at = summary.find(name + " ");
  ASSERT_NE(at, std::string::npos) << summary;
  const std::size_t header = summary.find("point ");
  const std::size_t header_line = summary.rfind('\n', header) + 1;
  const std::size_t row_line = summary.rfind('\n', at) + 1;
  // "range[m]" right-aligned over the range column: both columns end at the same offset.
  const std::size_t header_range = summary.find("range[m]", header) + 8 - header_line;
  const std::size_t range_start = summary.find_first_not_of(' ', at + name.size());
  const std::size_t row_range = summary.find(' ', range_start) - row_line;
  EXPECT_EQ(header_range, row_range) << summary;
}

// The terminal's tables stay aligned with "µm" (two bytes, one column) in headers and cells, and
// the task table's Monte Carlo interval has U's decimals (GUM 7.2.6: one decimal place per row).
TEST(Results, SummaryColumnsAlignWithMicrometres) {
  const std::string summary = SummaryText(SharedResults());
  auto columns = [](const std::string& text, std::size_t begin, std::size_t end) {
    std::size_t n = 0;
    for (std::size_t i = begin; i < end; ++i) n += (static_cast<unsigned char>(text[i]) & 0xC0) != 0x80;
    return n;
  };
  auto line_start = [&](std::size_t at) { return summary.rfind('\n', at) + 1; };
  // Point table: "a1[µm]" ends over the row's tenth field (name, range, x, y, z, Ux, Uy, Uz, |U|, a1).
  const std::size_t header = summary.find("a1[µm]");
  ASSERT_NE(header, std::string::npos) << summary;
  const std::size_t header_end = columns(summary, line_start(header), header + std::string("a1[µm]").size());
  const std::size_t row = summary.find('\n', header) + 1;
  std::size_t at = row;
  for (int field = 0; field < 10; ++field) {
    at = summary.find_first_not_of(' ', at);
    at = summary.find(' ', at);
  }
  EXPECT_EQ(columns(summary, row, at), header_end) << summary;
  // Task table: "U (GUM)" ends over the row's U ("... µm"), and the interval has U's decimals.
  const std::size_t task_header = summary.find("U (GUM)");
  ASSERT_NE(task_header, std::string::npos) << summary;
  const std::size_t u_end = columns(summary, line_start(task_header), task_header + 7);
  const std::size_t task_row = summary.find("\nAB ", task_header) + 1;
  const std::size_t row_end = summary.find('\n', task_row);
  const std::size_t u_unit = summary.find(" µm", task_row);
  ASSERT_LT(u_unit, row_end) << summary;
  EXPECT_EQ(columns(summary, task_row, u_unit + std::string(" µm").size()), u_end) << summary;
  const std::size_t u_start = summary.rfind(' ', u_unit - 1) + 1;
  const std::string u_text = summary.substr(u_start, u_unit - u_start);
  auto decimals = [](const std::string& number) {
    const std::size_t point = number.find('.');
    return point == std::string::npos ? std::size_t{0} : number.size() - point - 1;
  };
  const std::size_t open = summary.find('[', u_unit), comma = summary.find(", ", open);
  const std::size_t close = summary.find(']', comma);
  ASSERT_LT(close, row_end) << summary;
  const std::string low = summary.substr(open + 1, comma - open - 1), high = summary.substr(comma + 2, close - comma - 2);
  EXPECT_EQ(decimals(low), decimals(u_text)) << summary.substr(task_row, row_end - task_row);
  EXPECT_EQ(decimals(high), decimals(u_text)) << summary.substr(task_row, row_end - task_row);
}

TEST(Results, ReportIsSelfContained) {
  const Results& r = SharedResults();
  std::string html = ReportHtml(r);
  EXPECT_NE(html.find("<script id=\"vlt-data\" type=\"application/json\">"), std::string::npos);
  EXPECT_NE(html.find("plotly.js v"), std::string::npos);   // the library itself, inline
  EXPECT_EQ(html.find("<script src="), std::string::npos);  // nothing loaded from elsewhere
  EXPECT_EQ(html.find("@VLT_"), std::string::npos);         // every placeholder filled
  EXPECT_NE(html.find("id=\"vlt-status\""), std::string::npos);
  // plotly.js's MIT notice travels with it (its copyright line and the permission notice), in an
  // HTML comment before the script.
  const std::size_t notice = html.find("Permission is hereby granted, free of charge");
  const std::size_t copyright = html.find("Copyright (c) ");
  const std::size_t script = html.find("<script>/**");
  ASSERT_NE(notice, std::string::npos);
  ASSERT_NE(copyright, std::string::npos);
  EXPECT_NE(html.find("Plotly"), std::string::npos);
  EXPECT_LT(notice, script);
  EXPECT_LT(html.rfind("<!--", notice), notice);
  EXPECT_GT(html.find("-->", notice), notice);
}

class Writing : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        std::filesystem::temp_directory_path() /
        ("vlt_test_results_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::remove_all(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir_;
};

using Files = std::vector<std::pair<std::string, std::string>>;

int Entries(const std::filesystem::path& dir) {
  int n = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) {
    (void)e;
    ++n;
  }
  return n;
}

TEST_F(Writing, NewDirectoryHoldsExactlyTheFilesAndTheMarker) {
  std::filesystem::create_directories(dir_);
  OutputDirectory out(dir_ / "out");
  EXPECT_FALSE(std::filesystem::exists(dir_ / "out"));  // nothing before Commit
  out.Commit({{"points.csv", "1\n"}, {"results.json", "{}\n"}});
  EXPECT_EQ(Entries(dir_ / "out"), 3);  // two files + .vlt-output
  EXPECT_TRUE(std::filesystem::exists(dir_ / "out" / kOutputMarker));
  EXPECT_EQ(Entries(dir_), 1);  // no staging directory left beside it
}

TEST_F(Writing, ASecondRunReplacesTheWholeSet) {
  // Run A writes a map, run B does not: B's directory must not keep A's map (issue: stale files).
  std::filesystem::create_directories(dir_);
  OutputDirectory(dir_ / "out").Commit({{"points.csv", "A\n"}, {"map.csv", "A\n"}});
  OutputDirectory(dir_ / "out").Commit({{"points.csv", "B\n"}});
  EXPECT_FALSE(std::filesystem::exists(dir_ / "out" / "map.csv"));
  std::ifstream in(dir_ / "out" / "points.csv");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "B");
  EXPECT_EQ(Entries(dir_), 1);
}

TEST_F(Writing, ADirectoryVltDidNotWriteIsRefusedBeforeComputing) {
  std::filesystem::create_directories(dir_ / "mine");
  std::ofstream(dir_ / "mine" / "thesis.tex") << "precious";
  try {
    OutputDirectory out(dir_ / "mine");
    FAIL() << "accepted a foreign directory";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("holds 'thesis.tex', which vlt did not write"), std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(std::filesystem::exists(dir_ / "mine" / "thesis.tex"));
  // A path that is a file, and a parent that is a file.
  std::ofstream(dir_ / "file") << "x";
  EXPECT_THROW(OutputDirectory(dir_ / "file"), InputError);
  EXPECT_THROW(OutputDirectory(dir_ / "file" / "sub"), InputError);
  // An empty directory and one with an older vlt's outputs (no marker) are accepted.
  std::filesystem::create_directories(dir_ / "empty");
  EXPECT_NO_THROW(OutputDirectory(dir_ / "empty"));
  std::filesystem::create_directories(dir_ / "old");
  std::ofstream(dir_ / "old" / "points.csv") << "x";
  EXPECT_NO_THROW(OutputDirectory(dir_ / "old").Commit({{"tasks.csv", "y"}}));
  EXPECT_FALSE(std::filesystem::exists(dir_ / "old" / "points.csv"));
}

TEST_F(Writing, AFailedOrAbandonedRunLeavesTheOldSetAndNoStaging) {
  std::filesystem::create_directories(dir_);
  OutputDirectory(dir_ / "out").Commit({{"points.csv", "old\n"}});
  {
    OutputDirectory abandoned(dir_ / "out");  // e.g. the computation threw
  }
  EXPECT_THROW(OutputDirectory(dir_ / "out").Commit({{"bad/name.csv", "x"}}), InputError);
  std::ifstream in(dir_ / "out" / "points.csv");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "old");
  EXPECT_EQ(Entries(dir_), 1);
}

// Two runs into one directory (issue 32): a starting run removes the staging left by a killed run
// (its process is gone) but not another live run's, which then commits as it would have.
TEST_F(Writing, AnotherLiveRunsStagingIsLeftAlone) {
  std::filesystem::create_directories(dir_);
  const pid_t dead = ::fork();
  ASSERT_GE(dead, 0);
  if (dead == 0) ::_exit(0);
  ::waitpid(dead, nullptr, 0);  // reaped: no process has that pid now
  const std::filesystem::path live = dir_ / (".out.vlt-new-" + std::to_string(::getppid()));
  const std::filesystem::path stale = dir_ / (".out.vlt-new-" + std::to_string(dead));
  const std::filesystem::path old = dir_ / (".out.vlt-old-" + std::to_string(dead));
  for (const auto& p : {live, stale, old}) {
    std::filesystem::create_directories(p);
    std::ofstream(p / "points.csv") << "x\n";
  }
  OutputDirectory(dir_ / "out").Commit({{"points.csv", "new\n"}});
  EXPECT_TRUE(std::filesystem::exists(live / "points.csv")) << "a live run's staging was removed";
  EXPECT_FALSE(std::filesystem::exists(stale));
  EXPECT_FALSE(std::filesystem::exists(old));
  std::ifstream in(dir_ / "out" / "points.csv");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "new");
  std::filesystem::remove_all(live);
}

// An output file name past 255 bytes (made of a 300-character station name) is refused as such,
// not reported as "disk full?" when the write fails (issue 32); nothing is written.
TEST_F(Writing, AFileNameTooLongForTheFileSystemIsSaid) {
  std::filesystem::create_directories(dir_);
  try {
    OutputDirectory(dir_ / "out").Commit({{"simulated_" + std::string(300, 'S') + ".csv", "x\n"}});
    FAIL() << "accepted a 314-byte file name";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("longer than a file name may be (255)"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(Entries(dir_), 0);
}

TEST_F(Writing, SigtermWhileWritingRemovesTheStagingDirectory) {
  std::filesystem::create_directories(dir_);
  const std::filesystem::path target = dir_ / "out";
  // The child writes a large set; the parent sends SIGTERM as soon as the staging directory
  // appears. Retried: the child may finish first on a fast disk.
  for (int attempt = 0; attempt < 10; ++attempt) {
    std::filesystem::remove_all(target);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      InstallOutputSignalHandlers();
      Files files;
      for (int i = 0; i < 24; ++i)
        files.emplace_back("f" + std::to_string(i) + ".csv", std::string(4 << 20, 'x'));
      try {
        OutputDirectory(target).Commit(AsOutputFiles(files));
      } catch (...) {
        ::_exit(3);
      }
      ::_exit(0);
    }
    bool seen = false;
    for (int spin = 0; spin < 200000 && !seen; ++spin) {
      for (auto& e : std::filesystem::directory_iterator(dir_)) {
        if (e.path().filename().string().rfind(".out.vlt-new-", 0) == 0) seen = true;
      }
      if (!seen) ::usleep(20);
    }
    if (seen) ::kill(child, SIGTERM);
    int status = 0;
    ::waitpid(child, &status, 0);
    if (!seen || !WIFSIGNALED(status)) continue;  // finished before the signal: try again
    EXPECT_EQ(WTERMSIG(status), SIGTERM);
    EXPECT_EQ(Entries(dir_), 0) << "staging directory left behind";
    EXPECT_FALSE(std::filesystem::exists(target));
    return;
  }
  FAIL() << "the child always finished before SIGTERM arrived";
}

}  // namespace
}  // namespace vlt

namespace vlt {
namespace {

// A job too large for the memory is refused before computing, with one line naming the file,
// the size and what would fit (issue: 10^6 points died of std::bad_alloc after 18 minutes).
TEST(Results, JobTooLargeForMemoryIsAnInputError) {
  const Job job = ParseJob(kJob, "results.toml", ".");
  RunOptions gum_only;
  gum_only.monte_carlo = false;
  const std::uint64_t need = EstimateJobMemory(job, gum_only);
  // 4 points of a mirror job with environment, pose and thermal: 3 + 20 + 4 + 6 + 2 inputs each.
  EXPECT_EQ(need, kJobBaseBytes + 4 * (kBytesPerPoint + (3 + 20 + 4 + 6 + 2) * kBytesPerPointInput));
  // With Monte Carlo (4000 trials): the Monte Carlo part per point, one batch of float values of
  // the 12 point outputs + the task outputs, and all of them stored (4000 trials fit the budget).
  std::uint64_t outputs = 12;
  for (const TaskSpec& t : job.tasks) outputs += TaskOutputs(t.kind).size();
  EXPECT_EQ(EstimateJobMemory(job), need + 4 * kBytesPerPointMcm + 2 * 4 * outputs * 4000);
  EXPECT_NO_THROW(CheckJobMemory(job, need, gum_only));
  try {
    CheckJobMemory(job, need - 1, gum_only);
    FAIL();
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind("results.toml: plan: this job needs about ", 0), 0u) << m;
    EXPECT_NE(m.find("split it into jobs of at most 3 points"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos);
  }
}

}  // namespace
}  // namespace vlt

namespace vlt {
namespace {

// The numbers of every file: base_internal::Num is specified as the first of "%.6g" ... "%.17g" that
// reads back as the value (docs/results.md "Numbers"). The fast version (std::to_chars) must give
// the same characters: checked against that definition, evaluated with snprintf/strtod, over
// random bit patterns, values next to powers of two (where the rounding interval is asymmetric),
// and the magnitudes the files hold.
std::string NumBySpecification(double v) {
  char buffer[40];
  for (int precision = 6; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof buffer, "%.*g", precision, v);
    if (std::strtod(buffer, nullptr) == v) break;
  }
  return buffer;
}

TEST(Numbers, FastFormattingEqualsThePrintfDefinition) {
  std::uint64_t state = 0x9e3779b97f4a7c15ull;
  auto next = [&] {
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return state;
  };
  std::vector<double> values = {0.0,
                                -0.0,
                                1.0,
                                0.1,
                                0.5,
                                100000.0,
                                1234567.0,
                                1e-4,
                                1e-5,
                                2.42406840554768e-06,
                                1.9599639845400536,
                                50.000838e-3,
                                1e300,
                                5e-324,
                                -3.5,
                                123456.5};
  for (int i = 0; i < 200000; ++i) {
    double v;
    const std::uint64_t bits = next();
    std::memcpy(&v, &bits, sizeof v);
    if (std::isfinite(v)) values.push_back(v);
    const double scaled = static_cast<double>(next() % 2000001) * 1e-6 - 1.0;  // typical: mm, um, shares
    values.push_back(scaled * std::pow(10.0, static_cast<int>(next() % 21) - 10));
  }
  for (int e = -1074; e <= 1023; ++e) {  // powers of two and their neighbours
    const double p = std::ldexp(1.0, e);
    values.push_back(p);
    values.push_back(std::nextafter(p, 0.0));
    values.push_back(std::nextafter(p, 2 * p + 1));
  }
  int mismatches = 0;
  for (double v : values) {
    if (base_internal::Num(v) != NumBySpecification(v) && ++mismatches < 5) {
      ADD_FAILURE() << std::hexfloat << v << ": " << base_internal::Num(v) << " vs " << NumBySpecification(v);
    }
  }
  EXPECT_EQ(mismatches, 0) << "of " << values.size();
}

}  // namespace
}  // namespace vlt
