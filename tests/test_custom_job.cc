// Custom-model jobs (vlt/custom_job.h): the GUM annex H and JCGM 101 clause 9 examples against
// their published results, Type A inputs and effective degrees of freedom against closed forms,
// the multivariate t of simultaneous observations against its known moments, conformity against
// the normal distribution function, and bad input.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mcm/engine.h"
#include "vlt/conformity.h"
#include "vlt/custom_job.h"
#include "vlt/distributions.h"
#include "vlt/error.h"
#include "vlt/gum.h"
#include "vlt/job.h"
#include "vlt/models.h"
#include "vlt/results.h"

namespace vlt {
namespace {

const std::string kExamples = std::string(VLT_SOURCE_DIR) + "/examples/custom/";

CustomJob Parse(const std::string& text) {
  return ParseCustomJob(text, "job.toml", std::filesystem::path(kExamples));
}

RunOptions NoMcm() {
  RunOptions o;
  o.monte_carlo = false;
  return o;
}

RunOptions Trials(std::int64_t m) {
  RunOptions o;
  o.trials = m;
  return o;
}

const CustomOutputResult& Output(const CustomResults& r, const std::string& name) {
  for (const CustomOutputResult& o : r.outputs) {
    if (o.gum.name == name) return o;
  }
  throw std::runtime_error("no output " + name);
}

// JCGM 100 table G.2 (the values printed there, to their 2-3 decimals).
TEST(StudentTCoverageFactor, TableG2) {
  EXPECT_NEAR(StudentTCoverageFactor(0.95, 1), 12.71, 0.005);
  EXPECT_NEAR(StudentTCoverageFactor(0.95, 4), 2.78, 0.005);
  EXPECT_NEAR(StudentTCoverageFactor(0.95, 10), 2.23, 0.005);
  EXPECT_NEAR(StudentTCoverageFactor(0.99, 16), 2.92, 0.005);
  EXPECT_NEAR(StudentTCoverageFactor(0.9545, 20), 2.13, 0.005);
  EXPECT_NEAR(StudentTCoverageFactor(0.9973, 5), 5.51, 0.005);
  EXPECT_DOUBLE_EQ(StudentTCoverageFactor(0.95, std::numeric_limits<double>::infinity()),
                   NormalCoverageFactor(0.95));
  // Huge nu: the normal k (the incomplete beta function cannot resolve 1e15).
  EXPECT_NEAR(StudentTCoverageFactor(0.95, 1e15), NormalCoverageFactor(0.95), 1e-9);
  EXPECT_NEAR(StudentTCoverageFactor(0.95, 1e6), NormalCoverageFactor(0.95), 1e-5);
  // Heavy tails, closed forms: nu = 1 (Cauchy) tan(pi p / 2); nu = 2 p sqrt(2 / (1 - p^2)).
  EXPECT_NEAR(StudentTCoverageFactor(0.99999, 1), std::tan(0.5 * M_PI * 0.99999), 1e-6);
  EXPECT_NEAR(StudentTCoverageFactor(0.95, 2), 4.303, 0.0005);         // table G.2
  EXPECT_NEAR(StudentTCoverageFactor(0.95, 2.000001), 4.303, 0.0005);  // the numerical path agrees
  // Non-integer nu lies between its neighbours.
  const double k = StudentTCoverageFactor(0.95, 4.5);
  EXPECT_LT(k, StudentTCoverageFactor(0.95, 4));
  EXPECT_GT(k, StudentTCoverageFactor(0.95, 5));
}

TEST(WelchSatterthwaite, ClosedForm) {
  // Two components, u1^2 = 4, u2^2 = 1 with nu = 3 and 8: nu_eff = 25 / (16/3 + 1/8).
  EXPECT_NEAR(WelchSatterthwaite(std::sqrt(5.0), {4.0, 1.0}, {3.0, 8.0}), 25.0 / (16.0 / 3.0 + 1.0 / 8.0),
              1e-12);
  // Only infinite degrees of freedom: infinite.
  EXPECT_TRUE(std::isinf(WelchSatterthwaite(1.0, {1.0}, {std::numeric_limits<double>::infinity()})));
  // One component carries everything: its own nu.
  EXPECT_NEAR(WelchSatterthwaite(2.0, {4.0}, {7.0}), 7.0, 1e-12);
}

// GUM H.2: means, their standard uncertainties and correlations from the five simultaneous sets
// (table H.2), and R, X, Z with their uncertainties and correlations (table H.3).
TEST(CustomJob, GumH2PublishedValues) {
  const CustomJob job = LoadCustomJob(kExamples + "gum_h2_impedance.toml");
  ASSERT_EQ(job.inputs.size(), 3u);
  EXPECT_NEAR(job.inputs[0].estimate, 4.9990, 0.00005);
  EXPECT_NEAR(job.inputs[1].estimate, 19.6610e-3, 0.00005e-3);
  EXPECT_NEAR(job.inputs[2].estimate, 1.04446, 0.000005);
  EXPECT_NEAR(job.inputs[0].u, 0.0032, 0.00005);
  EXPECT_NEAR(job.inputs[1].u, 0.0095e-3, 0.00005e-3);
  EXPECT_NEAR(job.inputs[2].u, 0.00075, 0.000005);
  EXPECT_NEAR(job.correlation(0, 1), -0.36, 0.005);
  EXPECT_NEAR(job.correlation(0, 2), 0.86, 0.005);
  EXPECT_NEAR(job.correlation(1, 2), -0.65, 0.005);
  for (double nu : job.dof) EXPECT_EQ(nu, 4.0);
  ASSERT_EQ(job.simultaneous.size(), 1u);

  const CustomResults r = RunCustomJob(job, NoMcm());
  EXPECT_NEAR(Output(r, "R").gum.estimate, 127.732, 0.0005);
  EXPECT_NEAR(Output(r, "X").gum.estimate, 219.847, 0.0005);
  EXPECT_NEAR(Output(r, "Z").gum.estimate, 254.260, 0.0005);
  EXPECT_NEAR(Output(r, "R").gum.u, 0.071, 0.0005);
  EXPECT_NEAR(Output(r, "X").gum.u, 0.295, 0.001);  // 0.2956: the GUM prints 0.295
  EXPECT_NEAR(Output(r, "Z").gum.u, 0.236, 0.0005);
  EXPECT_NEAR(r.gum.correlation(0, 1), -0.588, 0.0005);
  EXPECT_NEAR(r.gum.correlation(0, 2), -0.485, 0.0005);
  EXPECT_NEAR(r.gum.correlation(1, 2), 0.993, 0.0005);
  // All inputs from the same 5 sets: one component, nu_eff = n - 1 = 4, k = t_95(4).
  for (const CustomOutputResult& o : r.outputs) {
    EXPECT_NEAR(o.gum.dof_effective, 4.0, 1e-9);
    EXPECT_NEAR(o.gum.k, StudentTCoverageFactor(0.95, 4), 1e-12);
  }
  ASSERT_TRUE(r.region.has_value());
  EXPECT_NEAR(r.region->gum_k, std::sqrt(7.814727903251178), 1e-9);  // chi2_3(0.95)
}

// Monte Carlo of GUM H.2 is refused: N = 3 inputs observed together n = 5 times give the
// multivariate t of JCGM 102 6.5.3 nu = n - N = 2 degrees of freedom, no covariance.
TEST(CustomJob, GumH2MonteCarloNeedsMoreObservations) {
  CustomJob job = LoadCustomJob(kExamples + "gum_h2_impedance.toml");
  EXPECT_FALSE(job.monte_carlo.enabled);  // the example says why
  job.monte_carlo.enabled = true;
  ASSERT_EQ(job.simultaneous_mcm_dof.size(), 1u);
  EXPECT_EQ(job.simultaneous_mcm_dof[0], 2.0);
  try {
    (void)RunCustomJob(job, Trials(10000));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(
        std::string(e.what()).find("gum_h2_impedance.toml: observations: Monte Carlo needs at least N + 3 "
                                   "simultaneous observations of N inputs"),
        std::string::npos)
        << e.what();
  }
}

// The multivariate t of simultaneous observations (JCGM 102 6.5.3) against its covariance
// Q / (n (n - N - 2)) computed here from the observations: n = 9 sets of N = 2 inputs x1, x2 of
// the additive model, y = x1 + x2 + x3 + x4 with x3, x4 ~ N(0, 1):
// var(y) = (Q11 + Q22 + 2 Q12) / (n (n - N - 2)) + 2.
TEST(CustomJob, SimultaneousObservationsMultivariateT) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "vlt_test_custom_mvt";
  std::filesystem::create_directories(dir);
  const double q1[9] = {1.2, 0.7, 1.9, 1.4, 0.3, 1.1, 1.6, 0.9, 1.0};
  const double q2[9] = {2.1, 1.8, 2.9, 2.2, 1.1, 2.4, 2.3, 2.0, 1.6};
  {
    std::ofstream csv(dir / "obs.csv");
    csv << "a,b\n";
    for (int k = 0; k < 9; ++k) csv << q1[k] << "," << q2[k] << "\n";
  }
  const CustomJob job = ParseCustomJob(R"(
[model]
name = "jcgm101_additive"
[observations]
file = "obs.csv"
simultaneous = true
[inputs.x1]
observations = "a"
[inputs.x2]
observations = "b"
)",
                                       "job.toml", dir);
  double m1 = 0, m2 = 0;
  for (int k = 0; k < 9; ++k) m1 += q1[k] / 9, m2 += q2[k] / 9;
  double q11 = 0, q22 = 0, q12 = 0;
  for (int k = 0; k < 9; ++k) {
    q11 += (q1[k] - m1) * (q1[k] - m1);
    q22 += (q2[k] - m2) * (q2[k] - m2);
    q12 += (q1[k] - m1) * (q2[k] - m2);
  }
  EXPECT_NEAR(job.correlation(0, 1), q12 / std::sqrt(q11 * q22), 1e-12);
  EXPECT_EQ(job.simultaneous_mcm_dof[0], 7.0);
  const CustomResults r = RunCustomJob(job, Trials(1000000));
  const double var_mcm_expected = (q11 + q22 + 2 * q12) / (9.0 * (9.0 - 2.0 - 2.0)) + 2.0;
  // The sample variance of 10^6 draws of a t_7 mixture: relative standard error below 0.3 %.
  EXPECT_NEAR(r.outputs[0].mcm.u * r.outputs[0].mcm.u / var_mcm_expected, 1.0, 0.012);
  // The GUM: u^2 = (Q11 + Q22 + 2 Q12) / (n (n - 1)) + 2, nu_eff from one component of nu = n - 1.
  const double var_gum = (q11 + q22 + 2 * q12) / (9.0 * 8.0) + 2.0;
  EXPECT_NEAR(r.outputs[0].gum.u * r.outputs[0].gum.u, var_gum, 1e-12 * var_gum);
  // The same seed gives bit-identical results for any number of threads (the chi-square draw of
  // the group is keyed by the trial like every other draw).
  RunOptions one = Trials(60000), two = Trials(60000);
  one.threads = 1;
  two.threads = 2;
  const CustomResults r1 = RunCustomJob(job, one), r2 = RunCustomJob(job, two);
  EXPECT_EQ(r1.outputs[0].mcm.mean, r2.outputs[0].mcm.mean);
  EXPECT_EQ(r1.outputs[0].mcm.u, r2.outputs[0].mcm.u);
  EXPECT_EQ(r1.outputs[0].mcm.shortest.low, r2.outputs[0].mcm.shortest.low);
  EXPECT_EQ(r1.outputs[0].mcm.shortest.high, r2.outputs[0].mcm.shortest.high);
  std::filesystem::remove_all(dir);
}

// Chi-square draws for the multivariate t: mean nu, variance 2 nu (fractional nu, nu < 2 too).
TEST(CustomJob, ChiSquareDrawMoments) {
  const mcm_internal::KeyedStream rng(7);
  for (double nu : {0.7, 1.0, 4.0, 9.5}) {
    const int n = 200000;
    double s1 = 0.0, s2 = 0.0;
    for (int i = 0; i < n; ++i) {
      const double w = mcm_internal::DrawChiSquare(rng, 3, static_cast<std::uint64_t>(i), nu);
      ASSERT_GT(w, 0.0);
      s1 += w;
      s2 += w * w;
    }
    const double mean = s1 / n, var = s2 / n - mean * mean;
    EXPECT_NEAR(mean, nu, 5.0 * std::sqrt(2.0 * nu / n)) << nu;
    EXPECT_NEAR(var / (2.0 * nu), 1.0, 0.05) << nu;
  }
}

// GUM H.1 with the degrees of freedom of table H.1 at p = 0.99 (H.1.6): nu_eff = 16,
// k = t_99(16) = 2.92, U = 93 nm; l = 50.000 838 mm, u = 32 nm (H.1.5).
TEST(CustomJob, GumH1EffectiveDegreesOfFreedom) {
  const CustomJob job = LoadCustomJob(kExamples + "gum_h1_end_gauge.toml");
  const CustomResults r = RunCustomJob(job, NoMcm());
  const CustomOutput& l = r.outputs[0].gum;
  EXPECT_NEAR(l.estimate, 0.050000838, 0.5e-9);
  EXPECT_NEAR(l.u, 32e-9, 0.5e-9);
  EXPECT_EQ(std::floor(l.dof_effective), 16.0);
  EXPECT_NEAR(l.k, 2.92, 0.005);
  EXPECT_NEAR(l.U, 93e-9, 0.5e-9);
  // Conformity of the example's tolerance [50.0000, 50.0009] mm: undetermined, and the
  // probability of conformity Phi((T_U - y) / u) (JCGM 106 7.3.2, closed form here).
  ASSERT_TRUE(r.outputs[0].conformity.has_value());
  EXPECT_EQ(r.outputs[0].conformity->verdict, "undetermined");
  // With nu_eff = 16 the t distribution function (JCGM 106 7.3.3, as U = t_99(16) u).
  const double expected =
      StudentTCdf((0.0500009 - l.estimate) / l.u, 16) - StudentTCdf((0.05 - l.estimate) / l.u, 16);
  EXPECT_NEAR(*r.outputs[0].conformity->probability_gum, expected, 1e-12);
  EXPECT_NEAR(expected, 0.966, 0.005);
}

// The second-order terms of JCGM 100 5.1.2 note against the published values: GUM H.1.7
// (u_c = 34 nm with them; the terms are l_s u(dalpha) u(theta) and l_s u(alpha_s) u(dtheta),
// closed form here) and JCGM 101 table 7 (GUF with the second-order terms: 0.0750 mg).
TEST(CustomJob, SecondOrderTermsPublished) {
  const CustomResults h1 = RunCustomJob(LoadCustomJob(kExamples + "gum_h1_end_gauge.toml"), NoMcm());
  const CustomOutput& l = h1.outputs[0].gum;
  const double ls = 0.050000623;
  const double closed = std::pow(ls * 0.58e-6 * 0.41, 2) + std::pow(ls * 1.2e-6 * 0.029, 2);
  EXPECT_NEAR(l.second_order_variance, closed, 1e-6 * closed);
  EXPECT_NEAR(std::sqrt(l.u * l.u + l.second_order_variance), 34e-9, 0.5e-9);
  EXPECT_FALSE(l.gum_reliable);
  const CustomResults mass = RunCustomJob(LoadCustomJob(kExamples + "jcgm101_mass.toml"), NoMcm());
  const CustomOutput& m = mass.outputs[0].gum;
  EXPECT_NEAR(std::sqrt(m.u * m.u + m.second_order_variance), 0.0750, 0.00005);
  EXPECT_FALSE(m.gum_reliable);
  // A linear model has none.
  const CustomResults add = RunCustomJob(Parse("[model]\nname = \"jcgm101_additive\"\n"), NoMcm());
  EXPECT_EQ(add.outputs[0].gum.second_order_variance, 0.0);
  EXPECT_TRUE(add.outputs[0].gum.gum_reliable);
}

// JCGM 101 9.3 mass calibration (table 7): GUF u = 0.0539 mg, MCM u = 0.0754 mg, shortest 95 %
// interval [1.0834, 1.3825] mg; the first-order GUM is not validated.
TEST(CustomJob, Jcgm101MassCalibration) {
  const CustomJob job = LoadCustomJob(kExamples + "jcgm101_mass.toml");
  const CustomResults r = RunCustomJob(job, Trials(1000000));
  const CustomOutputResult& o = r.outputs[0];
  EXPECT_NEAR(o.gum.estimate, 1.2340, 0.00005);
  EXPECT_NEAR(o.gum.u, 0.0539, 0.00005);
  EXPECT_NEAR(o.mcm.mean, 1.2341, 0.0003);  // ~3 standard errors of the mean (u / sqrt(M))
  EXPECT_NEAR(o.mcm.u, 0.0754, 0.0003);
  EXPECT_NEAR(o.mcm.shortest.low, 1.0834, 0.0015);
  EXPECT_NEAR(o.mcm.shortest.high, 1.3825, 0.0015);
  EXPECT_EQ(o.validation.outcome, "not validated");
}

// JCGM 101 9.2.3 and 9.2.4 (tables 3 and 4): the MCM 95 % intervals of sums with rectangular
// inputs, [-3.88, 3.88] and [-17.0, 17.0], against the GUM's +-3.92 and +-19.89.
TEST(CustomJob, Jcgm101AdditiveCases) {
  const CustomResults rect =
      RunCustomJob(LoadCustomJob(kExamples + "jcgm101_additive_rectangular.toml"), Trials(1000000));
  EXPECT_NEAR(rect.outputs[0].gum.U, 3.92, 0.005);
  EXPECT_NEAR(rect.outputs[0].mcm.symmetric.low, -3.88, 0.01);
  EXPECT_NEAR(rect.outputs[0].mcm.symmetric.high, 3.88, 0.01);
  const CustomResults dom =
      RunCustomJob(LoadCustomJob(kExamples + "jcgm101_additive_dominant.toml"), Trials(1000000));
  EXPECT_NEAR(dom.outputs[0].gum.u, 10.15, 0.005);
  EXPECT_NEAR(dom.outputs[0].gum.U, 19.89, 0.005);
  EXPECT_NEAR(dom.outputs[0].mcm.u, 10.15, 0.02);
  EXPECT_NEAR(dom.outputs[0].mcm.symmetric.low, -17.0, 0.05);
  EXPECT_NEAR(dom.outputs[0].mcm.symmetric.high, 17.0, 0.05);
  EXPECT_EQ(dom.outputs[0].validation.outcome, "not validated");
}

// Type A from an inline array: mean, s / sqrt(n), nu = n - 1 (JCGM 100 4.2), t for Monte Carlo.
TEST(CustomJob, TypeAInlineObservations) {
  const CustomJob job = Parse(R"(
[model]
name = "jcgm101_additive"
[inputs.x1]
observations = [1.0, 2.0, 4.0, 5.0, 3.0, 3.0]
[inputs.x2]
u = 0.5
dof = 10
)");
  const double mean = 3.0, s = std::sqrt((4 + 1 + 1 + 4 + 0 + 0) / 5.0);
  EXPECT_DOUBLE_EQ(job.inputs[0].estimate, mean);
  EXPECT_NEAR(job.inputs[0].u, s / std::sqrt(6.0), 1e-15);
  EXPECT_EQ(job.dof[0], 5.0);
  EXPECT_EQ(job.mcm_inputs[0].distribution, "student_t");
  EXPECT_EQ(job.mcm_inputs[0].shape, 5.0);
  EXPECT_NEAR(job.mcm_inputs[0].u, job.inputs[0].u * std::sqrt(5.0 / 3.0), 1e-15);
  EXPECT_EQ(job.sources[0].kind, "type A");
  EXPECT_EQ(job.sources[1].kind, "type B");
  // nu_eff by G.2b over x1 (nu 5), x2 (nu 10), x3, x4 (spec: u = 1, nu infinite).
  const CustomResults r = RunCustomJob(job, NoMcm());
  const double u1 = job.inputs[0].u, u2 = 0.5;
  const double uc2 = u1 * u1 + u2 * u2 + 2.0;
  const double nu = uc2 * uc2 / (std::pow(u1, 4) / 5.0 + std::pow(u2, 4) / 10.0);
  EXPECT_NEAR(r.outputs[0].gum.dof_effective, nu, 1e-9 * nu);
}

// Explicit correlation (rho = 1 allowed, JCGM 101 6.4.8.1) between two inputs of the additive
// model: u^2 = sum u_i^2 + 2 u1 u2.
TEST(CustomJob, CorrelationOfAnyInputs) {
  const CustomJob job = Parse(R"(
[model]
name = "jcgm101_additive"
[correlations.same_source]
inputs = ["x1", "x2"]
matrix = [[1, 1], [1, 1]]
)");
  const CustomResults r = RunCustomJob(job, Trials(100000));
  EXPECT_NEAR(r.outputs[0].gum.u, std::sqrt(4.0 + 2.0), 1e-12);
  EXPECT_NEAR(r.outputs[0].mcm.u, std::sqrt(6.0), 0.02 * std::sqrt(6.0));
}

// The Monte Carlo probability of conformity against the normal closed form (linear model, normal
// inputs: Y ~ N(0, 4)).
TEST(CustomJob, ConformityProbabilityMonteCarlo) {
  const CustomJob job = Parse(R"(
[model]
name = "jcgm101_additive"
[outputs.y.tolerance]
lower = -1.0
upper = 3.0
)");
  const CustomResults r = RunCustomJob(job, Trials(200000));
  const ConformityDecision& c = *r.outputs[0].conformity;
  const double p = StandardNormalCdf(1.5) - StandardNormalCdf(-0.5);
  EXPECT_NEAR(*c.probability_gum, p, 1e-12);
  ASSERT_TRUE(c.probability_mcm.has_value());
  EXPECT_NEAR(*c.probability_mcm, p, 5.0 * std::sqrt(p * (1 - p) / 200000.0));
  EXPECT_EQ(c.verdict, "undetermined");
}

TEST(Conformity, DecisionRule) {
  Tolerance t{-1.0, 1.0};
  EXPECT_EQ(DecideConformity(t, 0.0, 0.1, 0.2).verdict, "conforms");
  EXPECT_EQ(DecideConformity(t, 0.8, 0.1, 0.2).verdict, "conforms");  // 0.8 = 1 - U
  EXPECT_EQ(DecideConformity(t, 0.9, 0.1, 0.2).verdict, "undetermined");
  EXPECT_EQ(DecideConformity(t, 1.2, 0.1, 0.2).verdict, "undetermined");  // 1.2 = 1 + U
  EXPECT_EQ(DecideConformity(t, 1.3, 0.1, 0.2).verdict, "does not conform");
  EXPECT_EQ(DecideConformity(t, -1.3, 0.1, 0.2).verdict, "does not conform");
  // One-sided (a form tolerance): only the upper limit.
  Tolerance form;
  form.upper = 50e-6;
  const ConformityDecision d = DecideConformity(form, 30e-6, 5e-6, 10e-6);
  EXPECT_EQ(d.verdict, "conforms");
  EXPECT_NEAR(*d.probability_gum, StandardNormalCdf(4.0), 1e-15);
  EXPECT_EQ(DescribeTolerance(form, "m"), "<= 0.00005 m");
}

void ExpectError(const std::string& text, const std::string& fragment) {
  try {
    (void)Parse(text);
    FAIL() << "accepted: " << text;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
}

TEST(CustomJob, BadInputNamesFileAndKey) {
  ExpectError("[model]\nname = \"nope\"\n", "job.toml: model.name: 'nope' is not a compiled or built model");
  // [model] spec (vlt model build before the run): a spec that is not there is named with the key.
  ExpectError("[model]\nspec = \"no_such_spec.toml\"\n", "job.toml: model.spec: ");
  ExpectError("[model]\nspec = \"no_such_spec.toml\"\n", "no_such_spec.toml: cannot read the model spec");
  ExpectError("[model]\nname = \"mirror\"\n", "job.toml: model.name: 'mirror' is a tracker model");
  ExpectError("[model]\nname = \"jcgm101_additive\"\n[inputs.x9]\nu = 1\n",
              "job.toml: inputs.x9: model 'jcgm101_additive' has no input 'x9'");
  ExpectError("[model]\nname = \"jcgm101_additive\"\n[inputs.x1]\nobservations = [1, 2]\nu = 1\n",
              "job.toml: inputs.x1.u: an input with observations");
  ExpectError("[model]\nname = \"jcgm101_additive\"\n[inputs.x1]\nobservations = [1]\n",
              "job.toml: inputs.x1.observations: at least 2 observations");
  ExpectError("[model]\nname = \"jcgm101_additive\"\n[inputs.x1]\nobservations = \"V\"\n",
              "job.toml: inputs.x1.observations: a column name needs [observations]");
  ExpectError("[model]\nname = \"gum_h2_impedance\"\n[observations]\nfile = \"gum_h2_observations.csv\"\n",
              "job.toml: observations.simultaneous: required key is missing");
  ExpectError(
      "[model]\nname = \"gum_h2_impedance\"\n[observations]\nfile = \"nope.csv\"\nsimultaneous = true\n",
      "job.toml: observations.file: cannot read '");
  ExpectError(
      "[model]\nname = \"gum_h2_impedance\"\n[observations]\nfile = "
      "\"gum_h2_observations.csv\"\nsimultaneous = true\n[inputs.V]\nobservations = \"W\"\n",
      "has no column 'W'");
  ExpectError(
      "[model]\nname = \"jcgm101_additive\"\n[correlations.a]\ninputs = [\"x1\", \"x2\", \"x3\"]\nmatrix = "
      "[[1, 0.9, -0.9], [0.9, 1, 0.9], [-0.9, 0.9, 1]]\n",
      "job.toml: correlations.a.matrix: correlation matrix is not positive semi-definite");
  ExpectError(
      "[model]\nname = \"jcgm101_additive\"\n[correlations.a]\ninputs = [\"x1\", \"x2\"]\nmatrix = [[1, "
      "0.5], [0.5, 1]]\n[correlations.b]\ninputs = [\"x2\", \"x3\"]\nmatrix = [[1, 0.5], [0.5, 1]]\n",
      "job.toml: correlations.b.inputs: input 'x2' is already in correlation group 'a'");
  // An input of the simultaneous observations may not be correlated again by hand.
  ExpectError(
      "[model]\nname = \"gum_h2_impedance\"\n[observations]\nfile = "
      "\"gum_h2_observations.csv\"\nsimultaneous = true\n"
      "[inputs.V]\nobservations = \"V\"\n[inputs.phi]\nobservations = \"phi\"\n"
      "[correlations.a]\ninputs = [\"V\", \"I_amp\"]\nmatrix = [[1, 0.5], [0.5, 1]]\n",
      "job.toml: correlations.a.inputs: input 'V' is already in correlation group 'observations'");
  ExpectError("[model]\nname = \"jcgm101_additive\"\n[outputs.y.tolerance]\nlower = 2\nupper = 1\n",
              "job.toml: outputs.y.tolerance.upper: must be above lower");
  ExpectError("[model]\nname = \"jcgm101_additive\"\n[inputs.x1]\ndof = 0.5\n",
              "job.toml: inputs.x1.dof: degrees of freedom must be");
  ExpectError("[model]\nname = \"jcgm101_mass\"\n[inputs.rho_a]\nestimate = \"1.2 kg/m^3\"\n",
              "job.toml: inputs.rho_a.estimate: give a number in the model's unit (kg/m^3)");
}

// An [observations] file no input reads, or simultaneous with one reader: a warning each.
TEST(CustomJob, ObservationsWarnings) {
  const CustomJob unused = Parse(
      "[model]\nname = \"gum_h2_impedance\"\n[observations]\nfile = "
      "\"gum_h2_observations.csv\"\nsimultaneous = true\n");
  ASSERT_EQ(unused.warnings.size(), 1u);
  EXPECT_NE(unused.warnings[0].find("job.toml: observations.file: no input reads a column of"),
            std::string::npos)
      << unused.warnings[0];
  const CustomJob one = Parse(
      "[model]\nname = \"gum_h2_impedance\"\n[observations]\nfile = "
      "\"gum_h2_observations.csv\"\nsimultaneous = true\n[inputs.V]\nobservations = \"V\"\n");
  ASSERT_EQ(one.warnings.size(), 1u);
  EXPECT_NE(one.warnings[0].find("job.toml: observations.simultaneous: only one input reads"),
            std::string::npos)
      << one.warnings[0];
}

// Monte Carlo refuses Type A inputs with fewer than 4 observations (t with nu <= 2); the GUM runs.
TEST(CustomJob, TooFewObservationsForMonteCarlo) {
  const CustomJob job =
      Parse("[model]\nname = \"jcgm101_additive\"\n[inputs.x1]\nobservations = [1, 2, 4]\n");
  EXPECT_NO_THROW((void)RunCustomJob(job, NoMcm()));
  try {
    (void)RunCustomJob(job, Trials(10000));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("job.toml: inputs.x1.observations: Monte Carlo needs at least 4"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace vlt

namespace vlt {
namespace {

// Task tolerances in a tracker job: the GUM probability of conformity is the normal closed form
// at the task's y and u; the Monte Carlo one agrees within its binomial standard error; a form
// quantity of nominal points (no GUM value) is decided from the Monte Carlo interval.
TEST(TaskConformity, DistanceAndFlatness) {
  const char* text = R"(
[tracker]
model = "mirror"
[tracker.noise]
range = "5 um + 0.5 um/m"
azimuth = "0.5 arcsec"
elevation = "0.5 arcsec"
[plan]
point = [ {name = "A", x = 2, y = 0.5, z = 0}, {name = "B", x = 3, y = 1.5, z = 0.1},
          {name = "C", x = 2.5, y = 1.0, z = 0.6}, {name = "D", x = 4, y = -1, z = -0.3} ]
[[task]]
kind = "distance"
name = "AB"
points = ["A", "B"]
[task.tolerance.distance]
lower = "1.417740 m"
upper = "1.417750 m"
[[task]]
kind = "line"
name = "ABD"
points = ["A", "B", "D"]
[task.tolerance.straightness]
upper = "1 mm"
[monte_carlo]
trials = 100000
seed = 5
)";
  const Job job = ParseJob(text, "job.toml", ".");
  const Results r = RunJob(job);
  const TaskResult& d = r.tasks[0];
  ASSERT_TRUE(d.conformity[0].has_value());
  const double y = d.gum.value[0], u = d.gum.u[0];
  const double p = StandardNormalCdf((1.41775 - y) / u) - StandardNormalCdf((1.41774 - y) / u);
  EXPECT_NEAR(*d.conformity[0]->probability_gum, p, 1e-12);
  EXPECT_GT(p, 0.2);  // the test means something: neither 0 nor 1
  EXPECT_LT(p, 0.95);
  EXPECT_EQ(d.conformity[0]->verdict, "undetermined");
  ASSERT_TRUE(d.conformity[0]->probability_mcm.has_value());
  EXPECT_NEAR(*d.conformity[0]->probability_mcm, p, 5.0 * std::sqrt(p * (1 - p) / 1e5) + 1e-4);
  // The straightness of three points not on a line: a GUM value exists; of its quantities only
  // straightness has a tolerance.
  const TaskResult& l = r.tasks[1];
  int with = 0;
  for (const auto& c : l.conformity) with += c.has_value() ? 1 : 0;
  EXPECT_EQ(with, 1);
}

// A form quantity without a GUM value (straightness of collinear nominal points, docs/tasks.md)
// is decided from the Monte Carlo shortest interval; its GUM probability is absent.
TEST(TaskConformity, FormQuantityDecidedByMonteCarlo) {
  const std::string text = R"(
[tracker]
model = "mirror"
[tracker.noise]
range = "5 um + 0.5 um/m"
azimuth = "0.5 arcsec"
elevation = "0.5 arcsec"
[plan]
point = [ {name = "A", x = 2, y = -1, z = 0.2}, {name = "B", x = 3, y = 0, z = 0.2}, {name = "C", x = 4, y = 1, z = 0.2} ]
[[task]]
kind = "line"
name = "edge"
points = ["A", "B", "C"]
[task.tolerance.straightness]
upper = "LIMIT"
[monte_carlo]
trials = 20000
seed = 2
)";
  auto run = [&](const std::string& limit) {
    std::string t = text;
    t.replace(t.find("LIMIT"), 5, limit);
    return RunJob(ParseJob(t, "job.toml", "."));
  };
  const Results wide = run("1 mm");
  const TaskResult& task = wide.tasks[0];
  std::size_t q = 0;
  while (task.gum.quantities[q] != "straightness") ++q;
  ASSERT_FALSE(task.gum.differentiable[q]);
  const ConformityDecision& d = *task.conformity[q];
  EXPECT_FALSE(d.probability_gum.has_value());
  EXPECT_EQ(d.verdict, "conforms");  // the whole Monte Carlo interval (tens of um) is below 1 mm
  EXPECT_DOUBLE_EQ(*d.probability_mcm, 1.0);
  // A limit inside the interval: undetermined, and the Monte Carlo probability in (0, 1).
  const McmOutputResult& m = task.mcm[q];
  const double mid = 0.5 * (m.shortest.low + m.shortest.high);
  const Results tight = run(std::to_string(mid * 1e6) + " um");
  const ConformityDecision& t = *tight.tasks[0].conformity[q];
  EXPECT_EQ(t.verdict, "undetermined");
  EXPECT_GT(*t.probability_mcm, 0.05);
  EXPECT_LT(*t.probability_mcm, 0.95);
  // Below the whole interval: does not conform.
  const Results low = run(std::to_string(0.5 * m.shortest.low * 1e6) + " um");
  EXPECT_EQ(low.tasks[0].conformity[q]->verdict, "does not conform");
}

TEST(TaskConformity, BadTolerance) {
  const std::string base = R"(
[tracker]
model = "mirror"
[tracker.noise]
range = "5 um"
azimuth = "0.5 arcsec"
elevation = "0.5 arcsec"
[plan]
point = [ {name = "A", x = 2, y = 0.5, z = 0}, {name = "B", x = 3, y = 1.5, z = 0.1} ]
[[task]]
kind = "distance"
name = "AB"
points = ["A", "B"]
)";
  try {
    (void)ParseJob(base + "[task.tolerance.radius]\nupper = \"1 mm\"\n", "job.toml", ".");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "job.toml: task[0].tolerance.radius: a distance task has no quantity 'radius' (distance)"),
              std::string::npos)
        << e.what();
  }
  try {
    (void)ParseJob(base + "[task.tolerance.distance]\nupper = \"1 deg\"\n", "job.toml", ".");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("job.toml: task[0].tolerance.distance.upper"), std::string::npos)
        << e.what();
  }
}

}  // namespace
// JCGM 101 9.3's mass with the two masses exact and rho_a = 1.2, rho_W = rho_R: every first-order
// sensitivity is 0, the second-order terms (d2 y / d rho_a d rho_W) are not. The ratio has no value:
// infinite in the result, null in results.json, empty in outputs.csv, words in the summary; never a
// sentinel number (issue 31; it printed "2nd order 1e+300 x u^2").
TEST(CustomJob, FirstOrderZeroHasNoSecondOrderRatioNumber) {
  const CustomJob job = ParseCustomJob(R"(
[model]
name = "jcgm101_mass"
[inputs.m_Rc]
u = 0
[inputs.delta_m_Rc]
u = 0
)",
                                       "zero.toml", std::filesystem::path(kExamples));
  const CustomResults r = RunCustomJob(job, NoMcm());
  const CustomOutput& g = r.outputs[0].gum;
  EXPECT_EQ(g.u, 0.0);
  EXPECT_GT(g.second_order_variance, 0.0);
  EXPECT_TRUE(std::isinf(g.second_order_ratio));
  EXPECT_FALSE(g.gum_reliable);
  const auto files = ResultFiles(r);
  for (const auto& [name, text] : files) {
    EXPECT_EQ(text.find("1e+300"), std::string::npos) << name;
    if (name == "outputs.csv") {
      // The field under second_order_ratio is empty.
      const std::string header = text.substr(0, text.find('\n'));
      const std::string row =
          text.substr(header.size() + 1, text.find('\n', header.size() + 1) - header.size() - 1);
      auto field = [](const std::string& line, int k) {
        std::size_t begin = 0;
        for (int i = 0; i < k; ++i) begin = line.find(',', begin) + 1;
        return line.substr(begin, line.find(',', begin) - begin);
      };
      int column = 0;
      while (field(header, column) != "second_order_ratio") ++column;
      EXPECT_EQ(field(row, column), "");
    }
    if (name == "results.json") {
      EXPECT_TRUE(nlohmann::json::parse(text)["outputs"][0]["gum"]["second_order"]["ratio"].is_null());
    }
  }
}

}  // namespace vlt
