// The GPU kernel's source compiled as C++ on the CPU (issue 37, docs/gpu.md): the same lines as
// the kernel NVRTC compiles (base/portable_math.h, gpu/point_trials.h, the generated models'
// Forward) must give the CPU engine's values bit for bit. References: Random123's Philox4x32-10,
// the lanes of base/lanes.h, the generated ForwardLanes and the Monte Carlo engine's own job
// kernel (mcm_internal::JobTrialValues).
#include <gtest/gtest.h>

#include <Random123/philox.h>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <bit>
#include <cstdlib>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <span>
#include <sstream>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "generated/gum_h2_impedance.h"
#include "generated/head.h"
#include "generated/mirror.h"
#include "base/lanes.h"
#include "base/portable_math.h"
#include "gpu/point_trials.h"
#include "mcm/engine.h"
#include "mcm/gpu_run.h"
#include "test_mcm_helpers.h"
#include "gpu/kernel_source.h"
#include "gpu/trials.h"
#include "vlt/error.h"
#include "vlt/job.h"
#include "vlt/measurement_model.h"
#include "vlt/models.h"
#include "vlt/results.h"

#include <filesystem>
#include <fstream>
#include <iterator>

namespace vlt {
namespace {

std::uint64_t Bits(double x) { return std::bit_cast<std::uint64_t>(x); }

TEST(GpuKernel, PhiloxIsRandom123WordForWord) {
  std::mt19937_64 draw(37);
  for (int n = 0; n < 20000; ++n) {
    const std::uint64_t a = draw(), b = draw(), keys = draw();
    const r123::Philox4x32::ctr_type ctr = {{static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(a >> 32),
                                             static_cast<std::uint32_t>(b), static_cast<std::uint32_t>(b >> 32)}};
    const r123::Philox4x32::key_type key = {{static_cast<std::uint32_t>(keys), static_cast<std::uint32_t>(keys >> 32)}};
    const r123::Philox4x32::ctr_type expected = r123::Philox4x32()(ctr, key);
    unsigned int got[4];
    const unsigned int in[4] = {ctr[0], ctr[1], ctr[2], ctr[3]};
    base_internal::portable::Philox4x32(in, key[0], key[1], got);
    for (int j = 0; j < 4; ++j) ASSERT_EQ(got[j], expected[j]) << "word " << j << " of draw " << n;
  }
}

// The scalar SinCos is each lane of base/lanes.h SinCos: over random angles, every quadrant
// boundary's neighbours, signed zeros, the short series' limit, lanes all small and mixed, the
// reduction's limit 2^19 and beyond, infinities, NaN.
TEST(GpuKernel, ScalarSinCosIsEveryLaneOfTheSimdOne) {
  std::vector<double> xs = {0.0, -0.0, 1e-300, -1e-300, base_internal::portable::kSinCosReduced,
                            std::nextafter(base_internal::portable::kSinCosReduced, 1e300), -base_internal::portable::kSinCosReduced, 1e300,
                            std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                            std::numeric_limits<double>::quiet_NaN()};
  for (int k = -40; k <= 40; ++k) {
    const double boundary = k * 0.78539816339744830962;  // multiples of pi/4
    xs.push_back(std::nextafter(boundary, -1e300));
    xs.push_back(boundary);
    xs.push_back(std::nextafter(boundary, 1e300));
  }
  std::mt19937_64 draw(19);
  std::uniform_real_distribution<double> angle(-7.0, 7.0), wide(-6e5, 6e5), small(-1e-5, 1e-5);
  for (int n = 0; n < 40000; ++n) xs.push_back(n % 3 == 0 ? angle(draw) : n % 3 == 1 ? wide(draw) : small(draw));
  // The short series' limit kSmallAngle and its neighbours, and groups of four small angles (the
  // lanes then compute the short series alone).
  for (const double edge : {base_internal::portable::kSmallAngle, -base_internal::portable::kSmallAngle}) {
    xs.push_back(std::nextafter(edge, 0.0));
    xs.push_back(edge);
    xs.push_back(std::nextafter(edge, 2.0 * edge));
  }
  while (xs.size() % 4 != 0) xs.push_back(0.25);
  for (int n = 0; n < 4000; ++n) xs.push_back(small(draw));
  while (xs.size() % 4 != 0) xs.push_back(1.0);
  for (std::size_t i = 0; i < xs.size(); i += 4) {
    base_internal::lanes::Double4 s4, c4;
    base_internal::lanes::SinCos(base_internal::lanes::Load(&xs[i]), &s4, &c4);
    for (int l = 0; l < 4; ++l) {
      double s, c;
      base_internal::portable::SinCos(xs[i + l], &s, &c);
      if (std::isnan(s4[l])) {
        EXPECT_TRUE(std::isnan(s) && std::isnan(c)) << xs[i + l];
        continue;
      }
      ASSERT_EQ(Bits(s), Bits(s4[l])) << "sin of " << xs[i + l];
      ASSERT_EQ(Bits(c), Bits(c4[l])) << "cos of " << xs[i + l];
    }
  }
}

// The generated Forward on one base_internal::portable::Lane is each lane of the generated ForwardLanes (what the
// engine runs), for the tracker models with a lanes kernel.
template <int kParams, class Forward>
void ExpectForwardIsEveryLane(const char* name, Forward forward) {
  const ModelInfo* model = FindModel(name);
  ASSERT_NE(model, nullptr) << name;
  ASSERT_NE(model->forward_lanes, nullptr) << name;
  ASSERT_EQ(model->num_params, kParams);
  std::mt19937_64 draw(7);
  std::uniform_real_distribution<double> range(0.5, 40.0), azimuth(-7.0, 7.0), elevation(-1.2, 1.2),
      error(-3e-5, 3e-5);
  for (int n = 0; n < 5000; ++n) {
    double readings[3 * kForwardLanes], params[kParams * kForwardLanes], lanes_out[3 * kForwardLanes];
    for (int l = 0; l < kForwardLanes; ++l) {
      readings[l] = range(draw);
      readings[kForwardLanes + l] = azimuth(draw);
      readings[2 * kForwardLanes + l] = elevation(draw);
      for (int k = 0; k < kParams; ++k) params[kForwardLanes * k + l] = error(draw);
    }
    model->forward_lanes(readings, params, lanes_out, kForwardLanes, kForwardLanes);
    for (int l = 0; l < kForwardLanes; ++l) {
      base_internal::portable::Lane r[3], p[kParams], o[3];
      for (int j = 0; j < 3; ++j) r[j] = readings[kForwardLanes * j + l];
      for (int k = 0; k < kParams; ++k) p[k] = params[kForwardLanes * k + l];
      forward(r, p, o);
      for (int a = 0; a < 3; ++a) ASSERT_EQ(Bits(o[a].v), Bits(lanes_out[kForwardLanes * a + l])) << name << " output " << a;
    }
  }
}

// The same for GUM H.2's impedance, a custom model whose Forward calls sin and cos: its inputs near
// their estimates, the phase also over several turns.
TEST(GpuKernel, ACustomModelsForwardOnOneLaneIsEveryLaneOfTheEngines) {
  const ModelInfo* model = FindModel("gum_h2_impedance");
  ASSERT_NE(model, nullptr);
  ASSERT_NE(model->forward_lanes, nullptr);
  std::mt19937_64 draw(8);
  std::uniform_real_distribution<double> voltage(4.9, 5.1), current(0.0195, 0.0205), phase(-0.01, 0.01), turns(-20, 20);
  for (int n = 0; n < 5000; ++n) {
    double params[3 * kForwardLanes], lanes_out[3 * kForwardLanes];
    for (int l = 0; l < kForwardLanes; ++l) {
      params[l] = voltage(draw);
      params[kForwardLanes + l] = current(draw);
      params[2 * kForwardLanes + l] = n % 2 == 0 ? phase(draw) : turns(draw);
    }
    model->forward_lanes(nullptr, params, lanes_out, kForwardLanes, kForwardLanes);
    for (int l = 0; l < kForwardLanes; ++l) {
      base_internal::portable::Lane r[1], p[3], o[3];
      for (int k = 0; k < 3; ++k) p[k] = params[kForwardLanes * k + l];
      gen::gum_h2_impedance::Forward<base_internal::portable::Lane>(r, p, o);
      for (int a = 0; a < 3; ++a) ASSERT_EQ(Bits(o[a].v), Bits(lanes_out[kForwardLanes * a + l])) << "output " << a;
    }
  }
}

TEST(GpuKernel, GeneratedForwardOnOneLaneIsEveryLaneOfTheEngines) {
  ExpectForwardIsEveryLane<gen::mirror::kNumParams>("mirror", [](auto r, auto p, auto o) {
    gen::mirror::Forward<base_internal::portable::Lane>(r, p, o);
  });
  ExpectForwardIsEveryLane<gen::head::kNumParams>("head", [](auto r, auto p, auto o) {
    gen::head::Forward<base_internal::portable::Lane>(r, p, o);
  });
}

// The generated model namespace as PointTrial's Model.
struct Mirror {
  template <class S>
  static void Forward(const S* readings, const S* params, S* out) {
    gen::mirror::Forward<S>(readings, params, out);
  }
};
struct Head {
  template <class S>
  static void Forward(const S* readings, const S* params, S* out) {
    gen::head::Forward<S>(readings, params, out);
  }
};

UncertainInput Input(const char* name, double estimate, double u) {
  UncertainInput in;
  in.name = name;
  in.estimate = estimate;
  in.u = u;
  return in;
}

// Which of the stages the CPU prepares for the kernel a test job has.
// And whether the tracker's parameters are ones the kernel cannot draw itself (CpuDrawnParameters):
// then the CPU draws them for it.
struct Stages {
  bool air = false, pose = false, thermal = false;
  bool cpu_params = false;
  bool any() const { return air || pose || thermal; }
};
constexpr Stages kNoStage{}, kAllStages{true, true, true};

// The air (Ciddor, its humidity rectangular), a station pose and the part's thermal expansion,
// each uncertain, where `stages` says.
void AddStages(MeasurementSetup& setup, Stages stages) {
  Environment env;
  env.temperature = Input("environment.temperature", 20.5, 0.2);
  env.pressure = Input("environment.pressure", 101325.0, 30.0);
  env.humidity = Input("environment.humidity", 45.0, 5.0);
  env.humidity.distribution = "rectangular";
  env.co2 = Input("environment.co2", 450e-6, 30e-6);
  if (stages.air) setup.environment = env;
  StationPose pose;
  pose.rx = Input("pose.rx", 0.001, 1e-5);
  pose.ry = Input("pose.ry", -0.002, 1e-5);
  pose.rz = Input("pose.rz", 0.3, 1e-5);
  pose.tx = Input("pose.tx", 1.0, 10e-6);
  pose.ty = Input("pose.ty", -2.0, 10e-6);
  pose.tz = Input("pose.tz", 0.5, 10e-6);
  if (stages.pose) setup.pose = pose;
  PartThermal thermal;
  thermal.cte = Input("thermal.cte", 11.5e-6, 1e-6);
  thermal.temperature = Input("thermal.temperature", 21.0, 0.2);
  if (stages.thermal) setup.thermal = thermal;
}

// Parameters the kernel cannot draw itself: parameter 0 rectangular, parameter 1 arcsine, and
// parameters 3 (triangular) and 4 correlated (r = 0.7) with each other and parameter 5 with the
// part's temperature where the part is in the setup (r = -0.4) — the Gaussian copula's path, whose
// inverse CDFs (parameter 3's) call libm.
void CpuDrawnParameters(MeasurementSetup& setup) {
  setup.params[0].distribution = "rectangular";
  setup.params[1].distribution = "arcsine";
  setup.params[3].distribution = "triangular";
  CorrelationGroup pair;
  pair.name = "pair";
  pair.inputs = {setup.params[3].name, setup.params[4].name};
  pair.matrix = Eigen::Matrix2d{{1.0, 0.7}, {0.7, 1.0}};
  setup.correlations.push_back(pair);
  if (setup.thermal) {
    CorrelationGroup part;
    part.name = "part";
    part.inputs = {setup.params[5].name, "thermal.temperature"};
    part.matrix = Eigen::Matrix2d{{1.0, -0.4}, {-0.4, 1.0}};
    setup.correlations.push_back(part);
  }
}

MeasurementSetup NormalSetup(const char* name, Stages stages = kNoStage) {
  MeasurementSetup setup;
  AddStages(setup, stages);
  setup.model = FindModel(name);
  setup.params = test::DefaultParams(*setup.model);
  for (std::size_t k = 0; k < setup.params.size(); ++k) {
    // One parameter fixed (u = 0: no draw), the others normal with the model's u or 1 um / 1 urad.
    UncertainInput& in = setup.params[k];
    in.u = k == 2 ? 0.0 : in.u > 0.0 ? in.u : 1e-6;
    in.distribution = "normal";
    in.shape = 0.0;
  }
  setup.noise.range_a = 5e-6;
  setup.noise.range_b = 0.5e-6;
  setup.noise.azimuth = 4.8e-6;
  setup.noise.elevation = 4.8e-6;
  if (stages.cpu_params) CpuDrawnParameters(setup);
  return setup;
}

// The kernel's job for `job` (built here from the setup, independently of mcm/job.cc KernelJob).
gpu_internal::TrialsJob KernelTrials(const char* name, const MeasurementSetup& setup, const MeasurementModel& model,
                                     const McmJob& job, std::uint64_t seed) {
  gpu_internal::TrialsJob trials;
  trials.model = name;
  trials.job.seed = seed;
  trials.job.num_params = setup.model->num_params;
  // The readings' streams follow every shared input: the parameters, then the stages' inputs.
  trials.job.first_reading_stream = trials.job.num_params + (setup.environment ? 4 : 0) + (setup.pose ? 6 : 0) +
                                    (setup.thermal ? 2 : 0);
  trials.job.air = setup.environment.has_value();
  trials.job.pose = setup.pose.has_value();
  trials.job.thermal = setup.thermal.has_value();
  trials.job.params_drawn = !setup.correlations.empty() || setup.params[0].distribution != "normal";
  for (int k = 0; k < trials.job.num_params; ++k) {
    trials.job.param_estimate[k] = setup.params[k].estimate;
    trials.job.param_u[k] = setup.params[k].u;
  }
  trials.job.num_points = static_cast<int>(job.points.size());
  trials.points.resize(job.points.size());
  for (std::size_t p = 0; p < job.points.size(); ++p) {
    const Eigen::Vector3d u = model.reading_uncertainty(job.points[p].readings(0));
    for (int j = 0; j < 3; ++j) {
      trials.points[p].reading[j] = job.points[p].readings(j);
      trials.points[p].reading_u[j] = u(j);
    }
  }
  return trials;
}

// The parameters the CPU drew for the kernel are the draws the setup asks for (so that the
// comparison with the engine covers the copula and the non-normal marginals, not constants):
// the rectangular one within +-sqrt(3) u, the arcsine one within +-sqrt(2) u and dense near its
// ends, the triangular one within +-sqrt(6) u, the correlated pair's sample correlation near 0.698
// (the copula's r = 0.7 through the triangular marginal: 0.6985 in 4e5 draws of the same
// construction), and each with its standard deviation u.
void ExpectTheDrawnParametersFollowTheirDistributions(const MeasurementSetup& setup, const std::vector<double>& params,
                                                      int n) {
  auto row = [&](int k) { return std::span<const double>(params.data() + static_cast<std::size_t>(k) * n, n); };
  auto mean = [&](int k) {
    double m = 0.0;
    for (double x : row(k)) m += x / n;
    return m;
  };
  auto sd = [&](int k) {
    const double m = mean(k);
    double s = 0.0;
    for (double x : row(k)) s += (x - m) * (x - m) / (n - 1);
    return std::sqrt(s);
  };
  for (int k : {0, 1, 3, 4}) EXPECT_NEAR(sd(k), setup.params[k].u, 0.06 * setup.params[k].u) << "parameter " << k;
  // Draws beyond a distribution's half-width a = c u.
  auto beyond = [&](int k, double c) {
    int count = 0;
    for (double x : row(k)) count += std::abs(x - setup.params[k].estimate) > c * setup.params[k].u * (1 + 1e-12);
    return count;
  };
  EXPECT_EQ(beyond(0, std::sqrt(3.0)), 0);
  EXPECT_EQ(beyond(1, std::sqrt(2.0)), 0);
  EXPECT_EQ(beyond(3, std::sqrt(6.0)), 0);
  // Arcsine on [-a, a]: P(|x| > 0.9 a) = 1 - (2/pi) asin(0.9) = 0.287 (a rectangular one: 0.1 of
  // the same a; a normal of the same u: 0.203).
  EXPECT_NEAR(static_cast<double>(n - beyond(1, 0.9 * std::sqrt(2.0))) / n, 1.0 - 0.287, 0.04);
  // Triangular on [-a, a]: P(|x| > a / 2) = 1/4 (a normal of the same u: 0.22).
  EXPECT_NEAR(static_cast<double>(beyond(3, 0.5 * std::sqrt(6.0))) / n, 0.25, 0.025);
  double r = 0.0;
  const double m3 = mean(3), m4 = mean(4), s3 = sd(3), s4 = sd(4);
  for (int i = 0; i < n; ++i) r += (row(3)[i] - m3) * (row(4)[i] - m4) / ((n - 1) * s3 * s4);
  EXPECT_NEAR(r, 0.698, 0.05);
}

// Every value of every trial, against the engine's job kernel, from an unaligned first trial (the
// keyed streams give each trial its draws whatever batch it is in); with stages, each trial's as
// the CPU prepares them for the kernel.
template <class Model>
void ExpectTrialsAreTheEngines(const char* name, Stages with) {
  SCOPED_TRACE(::testing::Message() << "air " << with.air << ", pose " << with.pose << ", thermal " << with.thermal
                                    << ", parameters drawn on the CPU " << with.cpu_params);
  const bool with_stages = with.any();
  const MeasurementSetup setup = NormalSetup(name, with);
  const MeasurementModel model(setup);
  McmJob job;
  job.model = &model;
  job.points = {McmPoint{"P1", Eigen::Vector3d(3.0, 0.4, 0.1)}, McmPoint{"P2", Eigen::Vector3d(12.5, -2.0, -0.3)},
                McmPoint{"P3", Eigen::Vector3d(28.0, 3.1, 0.7)}};
  const std::uint64_t seed = 0x123456789abcdefull;
  const std::int64_t first = 999'997;
  const int n = 3000;
  const std::vector<double> engine = mcm_internal::JobTrialValues(job, seed, first, n);

  const gpu_internal::TrialsJob trials = KernelTrials(name, setup, model, job, seed);
  const gpu_internal::PointTrialsJob& kernel_job = trials.job;
  ASSERT_EQ(kernel_job.first_reading_stream, model.num_shared());
  ASSERT_EQ(kernel_job.params_drawn, with.cpu_params ? 1 : 0);
  const mcm_internal::CpuTrialInputs inputs =
      mcm_internal::JobTrialInputs(job, seed, first, n, mcm_internal::CpuTrialInputs::For(kernel_job));
  ASSERT_EQ(inputs.stages.size(), with_stages ? static_cast<std::size_t>(n) : 0u);
  ASSERT_EQ(inputs.params.size(), with.cpu_params ? static_cast<std::size_t>(kernel_job.num_params) * n : 0u);
  const std::vector<gpu_internal::TrialStages>& stages = inputs.stages;
  int differing = 0;
  for (int p = 0; p < kernel_job.num_points; ++p) {
    for (int i = 0; i < n; ++i) {
      double y[3];
      const gpu_internal::DrawnParams drawn{with.cpu_params ? inputs.params.data() + i : nullptr,
                                            static_cast<std::uint64_t>(n)};
      gpu_internal::PointOfTrial<Model>(kernel_job, trials.points[static_cast<std::size_t>(p)], p,
                                        static_cast<std::uint64_t>(first + i), with_stages ? &stages[i] : nullptr,
                                        drawn, y);
      for (int a = 0; a < 3; ++a) differing += Bits(y[a]) != Bits(engine[static_cast<std::size_t>(3 * p + a) * n + i]);
    }
  }
  // The host backend (the tests' GPU) lays the same values out as the engine's.
  std::vector<double> values(static_cast<std::size_t>(3 * kernel_job.num_points) * n);
  gpu_internal::HostBackend(trials)->Compute(static_cast<std::uint64_t>(first), n, inputs.prepared(), values.data());
  for (std::size_t v = 0; v < values.size(); ++v) differing += Bits(values[v]) != Bits(engine[v]);
  const int outputs = 3 * kernel_job.num_points;
  EXPECT_EQ(differing, 0) << name << ": values of " << n << " trials x " << outputs << " outputs, twice";
  // Not a comparison of constants: the trials spread as the inputs say (u of x at P3 > 10 um).
  double mean = 0.0, sq = 0.0;
  for (int i = 0; i < n; ++i) mean += engine[6 * static_cast<std::size_t>(n) + i] / n;
  for (int i = 0; i < n; ++i) sq += std::pow(engine[6 * static_cast<std::size_t>(n) + i] - mean, 2) / (n - 1);
  EXPECT_GT(std::sqrt(sq), 10e-6) << name;
  if (with_stages) {
    // Each stage really moved the trials (so that the comparison above covers it): the air's
    // range scale, the pose and the thermal scale differ from one, identity and one in every trial.
    int air = 0, pose = 0, thermal = 0;
    for (const gpu_internal::TrialStages& t : stages) {
      air += t.range_scale != 1.0;
      pose += t.rotation[1] != 0.0 && t.translation[0] != 0.0;
      thermal += t.thermal_scale != 1.0;
    }
    EXPECT_EQ(air, with.air ? n : 0);
    EXPECT_EQ(pose, with.pose ? n : 0);
    EXPECT_EQ(thermal, with.thermal ? n : 0);
  }
  if (with.cpu_params) ExpectTheDrawnParametersFollowTheirDistributions(setup, inputs.params, n);
}

TEST(GpuKernel, TrialsAreTheCpuEnginesBitForBit) {
  // No stage, all three, and each alone (the kernel's flags: one swapped would show).
  // Then with parameters the CPU draws for the kernel, with no stage and with all three (one of
  // them correlated with the part's temperature).
  for (Stages with : {kNoStage, kAllStages, Stages{true, false, false}, Stages{false, true, false},
                      Stages{false, false, true}, Stages{false, false, false, true}, Stages{true, true, true, true}}) {
    ExpectTrialsAreTheEngines<Mirror>("mirror", with);
    ExpectTrialsAreTheEngines<Head>("head", with);
  }
}

// What NVRTC is given is what these tests compiled: the embedded kernel files are the source
// tree's, byte for byte.
TEST(GpuKernel, EmbeddedSourcesAreTheFilesTheCpuBuildCompiles) {
  for (const char* name : {"base/portable_math.h", "gpu/point_trials.h", "generated/mirror.h", "generated/head.h",
                           "generated/total_station.h", "generated/jcgm101_additive.h", "generated/jcgm101_mass.h",
                           "generated/gum_h1_end_gauge.h", "generated/gum_h2_impedance.h"}) {
    const std::string where = std::string(name).rfind("generated/", 0) == 0 ? "" : "runtime/src/";
    std::ifstream in(std::filesystem::path(VLT_SOURCE_DIR) / (where + name), std::ios::binary);
    ASSERT_TRUE(in) << name;
    const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(gpu_internal::EmbeddedKernelFile(name), file) << name;
  }
  const gpu_internal::KernelSource source = gpu_internal::PointTrialsSource("head");
  EXPECT_NE(source.main.find("vlt::gen::head::Forward<S>"), std::string::npos);
  EXPECT_NE(source.main.find("extern \"C\" __global__ void vlt_point_trials"), std::string::npos);
  EXPECT_EQ(source.headers.size(), 4u);
  EXPECT_NE(gpu_internal::PointTrialsSource("jcgm101_mass").main.find("vlt::gen::jcgm101_mass::Forward<S>"),
            std::string::npos);
  // A model vlt does not carry (JCGM 102's polar example is built at run time): no source.
  EXPECT_THROW(gpu_internal::PointTrialsSource("polar"), std::invalid_argument);
}

// Runs the compiled kernel (`program`, in `dir`) on `trials` for trials first .. first + n - 1,
// with what the CPU prepared for them (`inputs`), and compares its values with the CPU engine's.
void ExpectProgramGivesTheEngines(const std::filesystem::path& dir, const std::string& program,
                                  const gpu_internal::TrialsJob& trials, const mcm_internal::CpuTrialInputs& inputs,
                                  std::int64_t first, int n, const std::vector<double>& engine,
                                  std::size_t marked = 0) {
  const gpu_internal::PointTrialsJob& kernel = trials.job;
  const std::vector<gpu_internal::TrialPoint>& points = trials.points;
  {
    std::ofstream in(dir / "job.bin", std::ios::binary);
    in.write(reinterpret_cast<const char*>(&kernel), sizeof kernel);
    in.write(reinterpret_cast<const char*>(points.data()), static_cast<std::streamsize>(points.size() * sizeof points[0]));
    in.write(reinterpret_cast<const char*>(inputs.stages.data()),
             static_cast<std::streamsize>(inputs.stages.size() * sizeof inputs.stages[0]));
    in.write(reinterpret_cast<const char*>(inputs.params.data()),
             static_cast<std::streamsize>(inputs.params.size() * sizeof inputs.params[0]));
  }
  const std::string run = program + " " + std::to_string(first) + " " + std::to_string(n) + " < " +
                          (dir / "job.bin").string() + " > " + (dir / "values.bin").string();
  ASSERT_EQ(std::system(run.c_str()), 0) << run;
  std::ifstream out(dir / "values.bin", std::ios::binary);
  std::vector<double> values(engine.size());
  out.read(reinterpret_cast<char*>(values.data()), static_cast<std::streamsize>(values.size() * sizeof(double)));
  ASSERT_EQ(out.gcount(), static_cast<std::streamsize>(values.size() * sizeof(double)));
  // The first `marked` values NaN (the kernel's mark: the CPU computes them), the others the
  // engine's bits.
  int differing = 0;
  for (std::size_t v = 0; v < values.size(); ++v) {
    differing += v < marked ? values[v] == values[v] : Bits(values[v]) != Bits(engine[v]);
  }
  EXPECT_EQ(differing, 0) << "of " << values.size() << " values, " << marked << " marked";
}

// The same on a two-point mirror job with the stages and parameters `with` says.
void ExpectCompiledKernelIsTheEngine(const std::filesystem::path& dir, const std::string& program, Stages with) {
  const bool with_stages = with.any();
  const MeasurementSetup setup = NormalSetup("mirror", with);
  const MeasurementModel model(setup);
  McmJob job;
  job.model = &model;
  job.points = {McmPoint{"P1", Eigen::Vector3d(4.0, 0.3, 0.2)}, McmPoint{"P2", Eigen::Vector3d(17.0, -1.0, -0.1)}};
  const std::uint64_t seed = 20090101;
  const std::int64_t first = 123'457;
  const int n = 2000;
  const std::vector<double> engine = mcm_internal::JobTrialValues(job, seed, first, n);
  const gpu_internal::TrialsJob trials = KernelTrials("mirror", setup, model, job, seed);
  const mcm_internal::CpuTrialInputs inputs =
      mcm_internal::JobTrialInputs(job, seed, first, n, mcm_internal::CpuTrialInputs::For(trials.job));
  ASSERT_EQ(inputs.stages.size(), with_stages ? static_cast<std::size_t>(n) : 0u);
  ASSERT_EQ(inputs.params.empty(), !with.cpu_params);
  ExpectProgramGivesTheEngines(dir, program, trials, inputs, first, n, engine);
}

// The same on a custom model (no readings, one "point" of its outputs), its inputs drawn by the
// kernel (`kernel_draws`: each normal or fixed, none correlated) or by the CPU.
void ExpectCompiledCustomKernelIsTheEngine(const std::filesystem::path& dir, const std::string& program,
                                           const ModelInfo& model, const std::vector<UncertainInput>& inputs,
                                           bool kernel_draws, int marked_outputs = 0) {
  const Eigen::MatrixXd independent;
  const std::uint64_t seed = 20080101;
  const std::int64_t first = 4'099;
  const int n = 2000;
  const std::vector<double> engine = mcm_internal::CustomTrialValues(model, inputs, independent, seed, first, n);
  const gpu_internal::TrialsJob trials = test::CustomKernelTrials(model, inputs, seed, kernel_draws);
  const mcm_internal::CpuTrialInputs drawn = mcm_internal::CustomTrialInputs(
      model, inputs, independent, seed, first, n, mcm_internal::CpuTrialInputs::For(trials.job));
  ASSERT_EQ(drawn.params.size(), kernel_draws ? 0u : static_cast<std::size_t>(model.num_params) * n);
  ExpectProgramGivesTheEngines(dir, program, trials, drawn, first, n, engine,
                               static_cast<std::size_t>(marked_outputs) * static_cast<std::size_t>(n));
}

// JCGM 101 9.3's mass calibration, its inputs all normal (drawn by the kernel) or, as the example
// has them (two normal, three rectangular), drawn by the CPU.
std::vector<UncertainInput> MassInputs(bool normal) {
  std::vector<UncertainInput> inputs = {Input("m_Rc", 100000.0, 0.05), Input("delta_m_Rc", 1.234, 0.02),
                                        Input("rho_a", 1.2, 0.1 / std::sqrt(3.0)), Input("rho_W", 8000.0, 1000.0 / std::sqrt(3.0)),
                                        Input("rho_R", 8000.0, 50.0 / std::sqrt(3.0))};
  for (std::size_t k = 2; !normal && k < inputs.size(); ++k) inputs[k].distribution = "rectangular";
  return inputs;
}

// A harness that stands in for CUDA's launch (__global__ empty, blockIdx/blockDim/threadIdx plain
// variables, every block run in turn), written to dir/harness.cc. stdin: the job, the points, each
// trial's stages where the job has any, the trials' parameters where the CPU drew them; argv:
// first trial, trials. stdout: the values.
void WriteFile(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

void WriteHarness(const std::filesystem::path& dir) {
  WriteFile(dir / "harness.cc", R"(#include <cmath>
#include <cstdio>
#include <cstdlib>
#define __global__
struct VltDim3 { unsigned x; };
static VltDim3 blockIdx, blockDim, threadIdx;
#include "vlt_point_trials.cu"
int main(int argc, char** argv) {
  vlt::gpu_internal::PointTrialsJob job;
  if (argc != 3 || fread(&job, sizeof job, 1, stdin) != 1) return 2;
  static vlt::gpu_internal::TrialPoint points[16];
  if (job.num_points > 16 || fread(points, sizeof points[0], job.num_points, stdin) != (size_t)job.num_points) return 2;
  const unsigned long long first = strtoull(argv[1], 0, 10);
  const int n = atoi(argv[2]);
  static double values[3 * 16 * 4096];
  static vlt::gpu_internal::TrialStages stages[4096];
  static double params[vlt::gpu_internal::kMaxParams * 4096];
  if (n > 4096) return 2;
  const bool staged = job.air || job.pose || job.thermal;
  if (staged && fread(stages, sizeof stages[0], n, stdin) != (size_t)n) return 2;
  const size_t drawn = job.params_drawn ? (size_t)job.num_params * n : 0;
  if (fread(params, sizeof params[0], drawn, stdin) != drawn) return 2;
  blockDim.x = 128;
  const unsigned long long threads = (unsigned long long)n * job.num_points;
  for (blockIdx.x = 0; blockIdx.x * 128ull < threads; ++blockIdx.x)
    for (threadIdx.x = 0; threadIdx.x < 128; ++threadIdx.x)
      vlt_point_trials(&job, points, staged ? stages : nullptr, drawn ? params : nullptr, first, n, values);
  fwrite(values, sizeof(double), (size_t)job.outputs_per_point * job.num_points * n, stdout);
  return 0;
}
)");
}

// The kernel source of `model` (PointTrialsSource: the embedded files, or `model_source`) written
// out as files in dir/<model>/ — main file and headers but NVRTC's <cmath> (the host has its own)
// — and the harness (WriteHarness) compiled with it by the host compiler; the program's path.
std::string CompiledKernel(const std::filesystem::path& dir, const std::string& model,
                           const std::string& model_source = "", const std::string& flags = "") {
  const std::filesystem::path model_dir = dir / (model + (flags.empty() ? "" : "-flagged"));
  const gpu_internal::KernelSource source = gpu_internal::PointTrialsSource(model, model_source);
  for (const auto& [name, text] : source.headers) {
    if (name != "cmath") WriteFile(model_dir / "include" / name, text);
  }
  WriteFile(model_dir / "vlt_point_trials.cu", source.main);
  const std::string program = (model_dir / "harness").string();
  const std::string command = std::string(VLT_TEST_CXX) + " -std=c++17 -O2 -ffp-contract=off " + flags + " -I" +
                              (model_dir / "include").string() + " -I" + model_dir.string() + " " +
                              (dir / "harness.cc").string() + " -o " + program;
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
  return program;
}

// The kernel source exactly as NVRTC is given it — main file and headers (but its <cmath> of three
// using-declarations), written out as files — compiled as C++ by the host compiler, with a harness that stands in for CUDA's launch
// (__global__ empty, blockIdx/blockDim/threadIdx plain variables, every block run in turn): its
// values are the CPU engine's, bit for bit.
TEST(GpuKernel, TheKernelSourceCompiledAsCppGivesTheEnginesValues) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("vlt-kernel-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  WriteHarness(dir);
  const std::string mirror = CompiledKernel(dir, "mirror");
  for (Stages with : {kNoStage, kAllStages, Stages{false, false, false, true}, Stages{true, true, true, true}}) {
    SCOPED_TRACE(::testing::Message() << "stages " << with.any() << ", parameters drawn on the CPU " << with.cpu_params);
    ExpectCompiledKernelIsTheEngine(dir, mirror, with);
  }
  const std::string mass = CompiledKernel(dir, "jcgm101_mass");
  for (bool normal : {true, false}) {
    SCOPED_TRACE(::testing::Message() << "jcgm101_mass, inputs drawn on the CPU " << !normal);
    ExpectCompiledCustomKernelIsTheEngine(dir, mass, *FindModel("jcgm101_mass"), MassInputs(normal), normal);
  }
  std::filesystem::remove_all(dir);
}

// Beyond its reduction's range (|x| > 2^19 rad) the kernel's sine and cosine would be the device's,
// whose bits need not be libm's: there the kernel marks the value NaN, for the CPU to compute
// (base/portable_math.h SinCos, mcm/gpu_run.cc). GUM H.2's impedance compiled as the device runs it
// (VLT_PORTABLE_MARKS_UNREDUCED): with its phase near 1 rad every value is the engine's; with the
// phase at 10^6 rad its resistance and reactance (the outputs through sin and cos) are marked in
// every trial and its modulus |Z| = V / I is the engine's.
TEST(GpuKernel, BeyondItsReductionTheKernelMarksTheTrialForTheCpu) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("vlt-marks-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  WriteHarness(dir);
  const std::string program = CompiledKernel(dir, "gum_h2_impedance", "", "-DVLT_PORTABLE_MARKS_UNREDUCED=1");
  const ModelInfo& model = *FindModel("gum_h2_impedance");
  std::vector<UncertainInput> inputs = {Input("V", 4.999, 0.0032), Input("I_amp", 0.019661, 0.0095e-3),
                                        Input("phi", 1.04446, 0.00075)};
  ExpectCompiledCustomKernelIsTheEngine(dir, program, model, inputs, true);
  inputs[2].estimate = 1e6;
  ExpectCompiledCustomKernelIsTheEngine(dir, program, model, inputs, true, 2);
  std::filesystem::remove_all(dir);
}

// Two custom models built at run time (vlt model build): a ratio and a norm of three inputs
// (+ - * / and sqrt), and a phase (atan2).
constexpr const char* kBuiltModelSpec = R"(
[model]
name = "%NAME%"
kind = "custom"
description = "A test model built at run time for the GPU kernel"
[[input]]
name = "a"
unit = "1"
quantity = "dimensionless"
description = "a"
estimate = 2.0
u = 0.01
distribution = "normal"
[[input]]
name = "b"
unit = "1"
quantity = "dimensionless"
description = "b"
estimate = 3.0
u = 0.02
distribution = "normal"
[[input]]
name = "c"
unit = "1"
quantity = "dimensionless"
description = "c"
estimate = 5.0
u = 0.05
distribution = "normal"
[[output]]
name = "first"
unit = "1"
quantity = "dimensionless"
description = "first"
expression = "%FIRST%"
[[output]]
name = "second"
unit = "1"
quantity = "dimensionless"
description = "second"
expression = "%SECOND%"
)";

// The model of kBuiltModelSpec with these outputs, built into the cache (VLT_MODEL_CACHE) from
// dir/<name>.toml.
const ModelInfo* BuildTestModel(const std::filesystem::path& dir, const std::string& name, const std::string& first,
                                const std::string& second) {
  std::string spec = kBuiltModelSpec;
  for (const auto& [key, value] : {std::pair<std::string, std::string>{"%NAME%", name}, {"%FIRST%", first}, {"%SECOND%", second}}) {
    spec.replace(spec.find(key), key.size(), value);
  }
  WriteFile(dir / (name + ".toml"), spec);
  BuildModel(dir / (name + ".toml"));
  return FindModel(name);
}

// A custom model built at run time: the generated header kept beside its library (model-<key>.h,
// BuiltModelSource) is the kernel's model source; the kernel compiled from it as C++ with the
// harness gives the CPU engine's values (the library's double Forward) bit for bit, its inputs
// drawn by the kernel or by the CPU. The custom Monte Carlo hands the GPU backend exactly that
// source; a built model whose equations call atan2 is refused, the call named. Not in the
// sanitizer build (the plugin is compiled without the sanitizers; stage 2's time).
TEST(GpuKernel, ABuiltModelsSourceGivesTheEnginesValues) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "sanitizer build";
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  GTEST_SKIP() << "sanitizer build";
#endif
#endif
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("vlt-built-kernel-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  ::setenv("VLT_MODEL_CACHE", (dir / "cache").c_str(), 1);
  struct Restore {  // also where an ASSERT returns early
    std::filesystem::path dir;
    ~Restore() {
      gpu_internal::SetBackendForTest(nullptr);
      ::unsetenv("VLT_MODEL_CACHE");
      std::filesystem::remove_all(dir);
    }
  } restore{dir};
  const ModelInfo* ratio = BuildTestModel(dir, "gpu_test_ratio", "a*b/c - a", "sqrt(a^2 + b^2 + c)");
  ASSERT_NE(ratio, nullptr);
  const std::string source = BuiltModelSource(*ratio);
  ASSERT_NE(source.find("void Forward("), std::string::npos);
  std::filesystem::path header = BuiltModels().front().library;
  header.replace_extension(".h");
  std::ifstream in(header, std::ios::binary);
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()), source);
  EXPECT_TRUE(BuiltModelSource(*FindModel("jcgm101_mass")).empty());

  WriteHarness(dir);
  const std::string program = CompiledKernel(dir, "gpu_test_ratio", source);
  std::vector<UncertainInput> inputs = {Input("a", 2.0, 0.01), Input("b", 3.0, 0.02), Input("c", 5.0, 0.05)};
  ExpectCompiledCustomKernelIsTheEngine(dir, program, *ratio, inputs, true);
  inputs[2].distribution = "rectangular";
  ExpectCompiledCustomKernelIsTheEngine(dir, program, *ratio, inputs, false);

  // What the custom Monte Carlo hands the backend: the built model's source, two outputs a trial.
  gpu_internal::TrialsJob handed;
  gpu_internal::SetBackendForTest([&handed](const gpu_internal::TrialsJob& trials, std::string* why_not) {
    handed = trials;
    *why_not = "recorded";
    return std::unique_ptr<gpu_internal::TrialsBackend>();
  });
  McmSettings settings;
  settings.trials = 1000;
  settings.device = McmDevice::kGpu;
  settings.device_where = "test";
  EXPECT_THROW(RunMcmCustom(*ratio, inputs, Eigen::MatrixXd(), settings), InputError);
  EXPECT_EQ(handed.model_source, source);
  EXPECT_EQ(handed.job.outputs_per_point, 2);
  EXPECT_EQ(handed.job.params_drawn, 1);
  const ModelInfo* phase = BuildTestModel(dir, "gpu_test_phase", "atan2(b, a)", "a + b + c");
  ASSERT_NE(phase, nullptr);
  const std::string why =
      "the GPU kernel runs a built model whose equations are + - * / and sqrt only; 'gpu_test_phase' calls atan2 "
      "(the C library's on the CPU, whose bits a GPU need not have)";
  try {
    RunMcmCustom(*phase, inputs, Eigen::MatrixXd(), settings);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "test: \"gpu\": " + why);
  }
  settings.device = McmDevice::kAuto;  // runs on the CPU and says why
  const McmResult on_cpu = RunMcmCustom(*phase, inputs, Eigen::MatrixXd(), settings);
  EXPECT_EQ(on_cpu.device, "cpu");
  EXPECT_EQ(on_cpu.device_note, why);
}

// A tracker job the kernel covers: the mirror tracker with its parameters (normal, one fixed),
// four points, a plane over them and a Monte Carlo map; nothing of [environment], [station], [part].
constexpr const char* kGpuJob = R"(
[job]
name = "gpu-path"
[tracker]
model = "mirror"
[tracker.noise]
range = "5 um + 0.5 um/m"
azimuth = "1 arcsec"
elevation = "1 arcsec"
[tracker.parameters]
tmv = {estimate = "0 um", u = "0 um"}
[plan]
unit = "m"
point = [
  {name = "A", x = 3, y = 0, z = 0},
  {name = "B", x = 4, y = 1, z = 0.05},
  {name = "C", x = 3, y = 1, z = 0.5},
  {name = "D", x = 5, y = -1, z = 0.2},
]
[[task]]
name = "face"
kind = "plane"
points = ["A", "B", "C", "D"]
[map]
plane = "z=0.3"
extent = "2,6,-2,2"
step = "1 m"
monte_carlo = true
[monte_carlo]
trials = 20000
seed = 11
)";

// The same job with every stage around the tracker model, drawn and prepared on the CPU for the
// kernel: the air (its humidity rectangular), a station pose and the part's thermal expansion.
const std::string kGpuJobWithStages = std::string(kGpuJob) + R"(
[environment]
temperature = { estimate = "20.5 degC", u = "0.2 K" }
pressure = { estimate = "1013.25 hPa", u = "0.3 hPa" }
humidity = { estimate = "45 %", u = "5 %", distribution = "rectangular" }
[station]
rz = { estimate = "0.3 rad", u = "2 arcsec" }
tx = { estimate = "0.2 m", u = "10 um" }
[part]
cte = { estimate = "11.5 ppm/K", u = "1 ppm/K" }
temperature = { estimate = "21 degC", u = "0.3 K" }
)";

// The same with the station's pose alone (the kernel's pose flag on, the others off).
const std::string kGpuJobWithPose = std::string(kGpuJob) + R"(
[station]
rz = { estimate = "0.3 rad", u = "2 arcsec" }
tx = { estimate = "0.2 m", u = "10 um" }
)";

// The same with tracker parameters the kernel cannot draw itself, so that the CPU draws them for
// it: a rectangular and an arcsine one, two correlated with each other (one triangular: the
// copula's inverse CDF), and one correlated with the part's temperature (a stage's input).
const std::string kGpuJobWithCpuDrawnParameters = std::string(kGpuJobWithStages) + R"(
[tracker.parameters.a0]
distribution = "rectangular"
[tracker.parameters.e0]
distribution = "arcsine"
[tracker.parameters.eac]
distribution = "triangular"
[tracker.correlations.axes]
parameters = ["eac", "eas"]
matrix = [[1, 0.6], [0.6, 1]]
[correlations.thermometer]
inputs = ["thermal.temperature", "R0"]
matrix = [[1, 0.5], [0.5, 1]]
)";

// The jobs the GPU path is checked on: kGpuJob, the same with every stage, with the pose alone and
// with parameters the CPU draws, and the demo's (vlt demo: the air, 34 points, 3 tasks) at 20 000
// trials.
std::vector<Job> GpuPathJobs() {
  std::vector<Job> jobs = {ParseJob(kGpuJob, "gpu.toml", "."), ParseJob(kGpuJobWithStages, "gpu-stages.toml", "."),
                           ParseJob(kGpuJobWithPose, "gpu-pose.toml", "."),
                           ParseJob(kGpuJobWithCpuDrawnParameters, "gpu-cpu-drawn.toml", "."),
                           ParseJob(std::string(DefaultJobToml()), kDefaultJobName, ".")};
  jobs.back().monte_carlo.trials = 20000;
  return jobs;
}

std::map<std::string, std::string> FilesOf(const Results& r) {
  std::map<std::string, std::string> files;
  for (const OutputFile& f : ResultFiles(r)) {
    StringText text;
    f.write(text);
    files[f.name] = text.text();
  }
  return files;
}

// The GPU path end to end — the engine's blocks of trials from a backend, the tasks on the CPU,
// the map's nodes — with the host backend standing in for a GPU: every file the same bytes as on
// the CPU but the lines that say where and how long the trials ran.
void ExpectTheSameFilesWithTheKernelOnTheHost(const Job& job) {
  SCOPED_TRACE(job.file);
  RunOptions cpu;
  cpu.threads = 3;
  cpu.device = McmDevice::kCpu;
  const Results on_cpu = RunJob(job, cpu);
  RunOptions gpu = cpu;
  gpu.device = McmDevice::kGpu;
  const Results on_gpu = test::WithTheKernelOnTheHost([&] { return RunJob(job, gpu); });
  EXPECT_EQ(on_cpu.mcm.device, "cpu");
  EXPECT_EQ(on_gpu.mcm.device.rfind("gpu: host", 0), 0u) << on_gpu.mcm.device;
  if (job.map && job.map->monte_carlo) {
    ASSERT_TRUE(on_gpu.map && on_gpu.map->has_mcm);
  }
  test::ExpectTheSameFilesButTheRunLines(FilesOf(on_cpu), FilesOf(on_gpu));
  EXPECT_GT(on_gpu.points[0].monte_carlo->axes[0].u, 0.0);
  // The summary names the device that ran the trials.
  EXPECT_NE(SummaryText(on_gpu).find("thread(s) and the GPU host ("), std::string::npos) << SummaryText(on_gpu);
  EXPECT_EQ(SummaryText(on_cpu).find("GPU"), std::string::npos);
}

TEST(GpuPath, TheSameFilesAsTheCpuWithTheKernelOnTheHost) {
  for (const Job& job : GpuPathJobs()) ExpectTheSameFilesWithTheKernelOnTheHost(job);
}

// device = "gpu" where no GPU works is one line naming the setting and why; "auto" runs on the CPU
// and says why. On a machine with a GPU the first part is skipped (the next test runs there).
TEST(GpuPath, GpuWithoutAWorkingOneIsAnInputErrorAndAutoSaysWhy) {
  Job job = ParseJob(kGpuJob, "gpu.toml", ".");
  job.map.reset();
  gpu_internal::TrialsJob probe;
  probe.model = "mirror";
  probe.job.num_params = 20;
  std::string why_not;
  if (gpu_internal::CudaBackend(probe, &why_not) != nullptr) GTEST_SKIP() << "a GPU works here";
  EXPECT_FALSE(why_not.empty());
  job.monte_carlo.device = McmDevice::kGpu;
  RunOptions options;
  options.trials = 2000;
  try {
    RunJob(job, options);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "gpu.toml: monte_carlo.device: \"gpu\": " + why_not);
  }
  job.monte_carlo.device = McmDevice::kAuto;
  const Results r = RunJob(job, options);
  EXPECT_EQ(r.mcm.device, "cpu");
  EXPECT_EQ(r.mcm.device_note, why_not);
}

// A backend whose values are not the CPU's (one value one ulp off) is never used: "auto" runs on
// the CPU and says why; "gpu" is refused. Checked on the first trials of every run.
class OneUlpOff final : public gpu_internal::TrialsBackend {
 public:
  explicit OneUlpOff(const gpu_internal::TrialsJob& trials) : host_(gpu_internal::HostBackend(trials)) {}
  void Compute(std::uint64_t first, int n, const gpu_internal::PreparedTrials& prepared, double* values) override {
    host_->Compute(first, n, prepared, values);
    values[n + 5] = std::nextafter(values[n + 5], 1e300);  // point 0, y, trial first + 5
  }
  std::string Description() const override { return "a broken GPU"; }

 private:
  std::unique_ptr<gpu_internal::TrialsBackend> host_;
};

TEST(GpuPath, AGpuWhoseValuesAreNotTheCpusIsNotUsed) {
  Job job = ParseJob(kGpuJob, "gpu.toml", ".");
  job.map.reset();
  gpu_internal::SetBackendForTest(
      [](const gpu_internal::TrialsJob& trials, std::string*) { return std::make_unique<OneUlpOff>(trials); });
  RunOptions options;
  options.trials = 2000;
  options.device = McmDevice::kAuto;
  const Results r = RunJob(job, options);
  EXPECT_EQ(r.mcm.device, "cpu");
  EXPECT_EQ(r.mcm.device_note,
            "a broken GPU: its values differ from the CPU's in 1 of 768 (the first 64 trials checked): not used");
  options.device = McmDevice::kGpu;
  try {
    RunJob(job, options);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "command line: --device: \"gpu\": " + r.mcm.device_note);
  }
  gpu_internal::SetBackendForTest(nullptr);
}

// A block holds trials the run never uses (here the 2096 past M = 2000 of the first block of
// 4096): one of them with a drawn humidity past 100 % — which the CPU's stages refuse — is not
// the run's error, nor the GPU's. The run gives the CPU's files and no note.
TEST(GpuPath, AnInputErrorPastTheRunsTrialsIsNotAnError) {
  Job job = ParseJob(std::string(kGpuJob) + R"(
[environment]
temperature = { estimate = "20.5 degC", u = "0.2 K" }
pressure = { estimate = "1013.25 hPa", u = "0.3 hPa" }
humidity = { estimate = "99 %", u = "0.3 %" }
)", "humid.toml", ".");
  job.map.reset();
  job.monte_carlo.seed = 2;
  RunOptions cpu;
  cpu.device = McmDevice::kCpu;
  // Not vacuous: the first 4096 trials hold such a draw, the first 2000 none.
  cpu.trials = 4096;
  EXPECT_THROW(RunJob(job, cpu), InputError);
  cpu.trials = 2000;
  const Results on_cpu = RunJob(job, cpu);
  gpu_internal::SetBackendForTest(
      [](const gpu_internal::TrialsJob& trials, std::string*) { return gpu_internal::HostBackend(trials); });
  for (McmDevice device : {McmDevice::kGpu, McmDevice::kAuto}) {
    RunOptions gpu = cpu;
    gpu.device = device;
    const Results on_gpu = RunJob(job, gpu);
    EXPECT_EQ(on_gpu.mcm.device.rfind("gpu: host", 0), 0u) << on_gpu.mcm.device;
    EXPECT_EQ(on_gpu.mcm.device_note, "");
    std::map<std::string, std::string> a = FilesOf(on_cpu), b = FilesOf(on_gpu);
    for (const char* name : {"points.csv", "points.jsonl", "budget.csv", "tasks.csv"}) {
      EXPECT_TRUE(a[name] == b[name]) << name << " differs";
    }
  }
  gpu_internal::SetBackendForTest(nullptr);
}

// What the CPU prepares for a block (the stages, the parameters it draws) is prepared by every
// engine thread that needs the block (mcm/job.cc SharedPreparation): on 1, 2, 3 and 16 threads the
// GPU path's files are the CPU's, byte for byte.
TEST(GpuPath, BlocksPreparedBySeveralThreadsGiveTheSameFiles) {
  Job job = ParseJob(kGpuJobWithCpuDrawnParameters, "gpu-cpu-drawn.toml", ".");
  job.map.reset();
  RunOptions cpu;
  cpu.threads = 1;
  cpu.device = McmDevice::kCpu;
  const std::map<std::string, std::string> on_cpu = FilesOf(RunJob(job, cpu));
  gpu_internal::SetBackendForTest(
      [](const gpu_internal::TrialsJob& trials, std::string*) { return gpu_internal::HostBackend(trials); });
  for (int threads : {1, 2, 3, 16}) {
    SCOPED_TRACE(::testing::Message() << threads << " thread(s)");
    RunOptions gpu = cpu;
    gpu.threads = threads;
    gpu.device = McmDevice::kGpu;
    const Results r = RunJob(job, gpu);
    EXPECT_EQ(r.mcm.device.rfind("gpu: host", 0), 0u) << r.mcm.device;
    std::map<std::string, std::string> on_gpu = FilesOf(r);
    for (const char* name : {"points.csv", "points.jsonl", "budget.csv", "tasks.csv"}) {
      EXPECT_TRUE(on_cpu.at(name) == on_gpu[name]) << name << " differs";
    }
  }
  gpu_internal::SetBackendForTest(nullptr);
}

// The host backend, its values of every 97th trial NaN: what the kernel gives where it cannot
// promise the CPU's bits (beyond SinCos's reduction).
class MarksSomeTrials final : public gpu_internal::TrialsBackend {
 public:
  explicit MarksSomeTrials(const gpu_internal::TrialsJob& trials)
      : host_(gpu_internal::HostBackend(trials)), outputs_(trials.job.outputs_per_point * trials.job.num_points) {}
  void Compute(std::uint64_t first, int n, const gpu_internal::PreparedTrials& prepared, double* values) override {
    host_->Compute(first, n, prepared, values);
    for (int i = 0; i < n; ++i) {
      if ((first + static_cast<std::uint64_t>(i)) % 97 != 0) continue;
      for (int o = 0; o < outputs_; ++o) values[static_cast<std::size_t>(o) * n + i] = std::nan("");
    }
  }
  std::string Description() const override { return "host, marking"; }

 private:
  std::unique_ptr<gpu_internal::TrialsBackend> host_;
  int outputs_;
};

// Trials the device marked NaN are computed by the CPU: the run is on the GPU (the run-time check
// skips the marked values) and its files are the CPU's, byte for byte, on 1 and 3 threads.
TEST(GpuPath, TrialsTheDeviceMarkedAreTheCpus) {
  Job job = ParseJob(kGpuJob, "gpu.toml", ".");
  job.map.reset();
  RunOptions cpu;
  cpu.trials = 30000;
  cpu.device = McmDevice::kCpu;
  const std::map<std::string, std::string> on_cpu = FilesOf(RunJob(job, cpu));
  gpu_internal::SetBackendForTest([](const gpu_internal::TrialsJob& trials, std::string*) {
    return std::unique_ptr<gpu_internal::TrialsBackend>(std::make_unique<MarksSomeTrials>(trials));
  });
  for (int threads : {1, 3}) {
    RunOptions gpu = cpu;
    gpu.threads = threads;
    gpu.device = McmDevice::kGpu;
    const Results r = RunJob(job, gpu);
    EXPECT_EQ(r.mcm.device, "gpu: host, marking");
    const std::map<std::string, std::string> on_gpu = FilesOf(r);
    for (const char* name : {"points.csv", "points.jsonl", "budget.csv", "tasks.csv"}) {
      EXPECT_TRUE(on_cpu.at(name) == on_gpu.at(name)) << name << " differs on " << threads << " thread(s)";
    }
  }
  gpu_internal::SetBackendForTest(nullptr);
}

// The host backend, recording the first trial of each block it computes (the run-time check's
// trials 0 .. 63 apart).
class RecordsBlocks final : public gpu_internal::TrialsBackend {
 public:
  RecordsBlocks(const gpu_internal::TrialsJob& trials, std::vector<std::pair<std::uint64_t, int>>* blocks,
                std::mutex* mutex)
      : host_(gpu_internal::HostBackend(trials)), blocks_(blocks), mutex_(mutex) {}
  void Compute(std::uint64_t first, int n, const gpu_internal::PreparedTrials& prepared, double* values) override {
    {
      const std::lock_guard<std::mutex> lock(*mutex_);
      blocks_->emplace_back(first, n);
    }
    host_->Compute(first, n, prepared, values);
  }
  std::string Description() const override { return "host, recording"; }

 private:
  std::unique_ptr<gpu_internal::TrialsBackend> host_;
  std::vector<std::pair<std::uint64_t, int>>* blocks_;
  std::mutex* mutex_;
};

// A thread that would wait for a block another thread computes hands the device the next one
// instead (mcm/gpu_run.cc GpuTrialKernel::Ahead): on 1, 2, 3 and 16 threads, with a fixed M not a
// multiple of the block, every block is computed exactly once, none past M, and the files are the
// CPU's, byte for byte; with the run-time check's 64 trials first.
TEST(GpuPath, BlocksComputedAheadAreEachComputedOnceAndNonePastM) {
  Job job = ParseJob(kGpuJob, "gpu.toml", ".");
  job.map.reset();
  RunOptions cpu;
  cpu.threads = 1;
  cpu.trials = 70000;  // blocks of max(4096, M / 8) = 8750 trials: 8 blocks
  cpu.device = McmDevice::kCpu;
  const std::map<std::string, std::string> on_cpu = FilesOf(RunJob(job, cpu));
  for (int threads : {1, 2, 3, 16}) {
    SCOPED_TRACE(::testing::Message() << threads << " thread(s)");
    std::vector<std::pair<std::uint64_t, int>> blocks;
    std::mutex mutex;
    gpu_internal::SetBackendForTest([&](const gpu_internal::TrialsJob& trials, std::string*) {
      return std::unique_ptr<gpu_internal::TrialsBackend>(std::make_unique<RecordsBlocks>(trials, &blocks, &mutex));
    });
    RunOptions gpu = cpu;
    gpu.threads = threads;
    gpu.device = McmDevice::kGpu;
    const Results r = RunJob(job, gpu);
    gpu_internal::SetBackendForTest(nullptr);
    EXPECT_EQ(r.mcm.device, "gpu: host, recording");
    ASSERT_FALSE(blocks.empty());
    EXPECT_EQ(blocks.front(), (std::pair<std::uint64_t, int>{0, 64}));  // the run-time check
    std::vector<std::uint64_t> firsts;
    for (std::size_t b = 1; b < blocks.size(); ++b) {
      EXPECT_EQ(blocks[b].second, 8750);
      firsts.push_back(blocks[b].first);
    }
    std::sort(firsts.begin(), firsts.end());
    std::vector<std::uint64_t> expected;
    for (std::uint64_t first = 0; first < 70000; first += 8750) expected.push_back(first);
    EXPECT_EQ(firsts, expected);
    const std::map<std::string, std::string> on_gpu = FilesOf(r);
    for (const char* name : {"points.csv", "points.jsonl", "budget.csv", "tasks.csv"}) {
      EXPECT_TRUE(on_cpu.at(name) == on_gpu.at(name)) << name << " differs";
    }
  }
}

// A kernel of one output, trial t's value t, for the block machinery alone.
class TrialIndexKernel final : public mcm_internal::MirroredKernel {
 public:
  int num_outputs() const override { return 1; }
  void InitScratch(mcm_internal::Scratch&) const override {}
  std::vector<double> AtEstimates() const override { return {0.0}; }
  void Run(const mcm_internal::KeyedStream&, std::int64_t first, int n, mcm_internal::Scratch&,
           double* outputs) const override {
    for (int i = 0; i < n; ++i) outputs[i] = static_cast<double>(first + i);
  }
  void PrepareTrials(const mcm_internal::KeyedStream&, std::int64_t, int, mcm_internal::Scratch&,
                     gpu_internal::TrialStages*, double*, std::int64_t) const override {}
  void RunTasks(int, mcm_internal::Scratch&, double*) const override {}
  void TrialsRunBefore(std::int64_t end) const override { ends.push_back(end); }

  mutable std::vector<std::int64_t> ends;  // TrialsRunBefore's, in order
};

// Its device: records each block it computes (as it starts it); each block waits at its gate
// until the test opens it.
class GatedBlocks final : public gpu_internal::TrialsBackend {
 public:
  void Compute(std::uint64_t first, int n, const gpu_internal::PreparedTrials&, double* values) override {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      computed_.push_back(first);
      changed_.notify_all();
      changed_.wait(lock, [&] { return open_.count(first) > 0; });
    }
    for (int i = 0; i < n; ++i) values[i] = static_cast<double>(first + static_cast<std::uint64_t>(i));
  }
  std::string Description() const override { return "host, gated"; }

  void Open(std::uint64_t first) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      open_.insert(first);
    }
    changed_.notify_all();
  }
  void WaitUntilStarted(std::size_t blocks) {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [&] { return computed_.size() >= blocks; });
  }
  std::vector<std::uint64_t> Computed() {
    const std::lock_guard<std::mutex> lock(mutex_);
    return computed_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::uint64_t> computed_;
  std::set<std::uint64_t> open_;
};

// The interleaving behind a block computed twice on 16 threads (a CI run of 2026-11-28). The
// device computes one block at a time. A needs block 1 and computes it; B needs block 0 and
// computes it after; block 1's trials are all copied out while block 0 is still on the device, so
// that block 1's entry is forgotten; C, which needs block 0 too, would rather not wait and hands the
// device the block after it: block 1 again, where it must compute nothing.
TEST(GpuPath, ABlockCopiedOutIsNotComputedAheadAgain) {
  const TrialIndexKernel cpu;
  auto owned = std::make_unique<GatedBlocks>();
  GatedBlocks& device = *owned;
  const std::int64_t block = 4096;  // max(4096, M / 8)
  const mcm_internal::GpuTrialKernel gpu(cpu, 1, std::move(owned), {}, 8 * block, /*fall_back=*/false);
  const mcm_internal::KeyedStream rng(1);
  auto run = [&](std::int64_t first) {
    mcm_internal::Scratch scratch;
    std::vector<double> outputs(mcm_internal::kSubBatch);
    gpu.Run(rng, first, mcm_internal::kSubBatch, scratch, outputs.data());
    for (int i = 0; i < mcm_internal::kSubBatch; ++i) EXPECT_EQ(outputs[static_cast<std::size_t>(i)], first + i);
  };
  std::thread a(run, block);
  device.WaitUntilStarted(1);
  std::thread b(run, 0);
  device.Open(block);
  a.join();
  device.WaitUntilStarted(2);
  for (std::int64_t first = block + mcm_internal::kSubBatch; first < 2 * block; first += mcm_internal::kSubBatch) {
    run(first);
  }
  std::thread c(run, mcm_internal::kSubBatch);
  // C either claims block 1 again at once (the fault) or waits for block 0: give it the time to do
  // the former before block 0 is let through. A fault missed is never a false failure.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  device.Open(0);
  device.Open(block);  // block 1 a second time, where the fault asks for it
  b.join();
  c.join();
  EXPECT_EQ(device.Computed(), (std::vector<std::uint64_t>{static_cast<std::uint64_t>(block), 0}));
}

// A block is forgotten once its trials were copied out; where they never all are — a fixed M's
// last block holds trials past M, and under MPI a rank copies out only its share of a block — the
// engine's wave forgets them when done (TrialsRunBefore). Each block is computed once.
TEST(GpuPath, BlocksWhoseTrialsAreNotAllCopiedOutAreForgottenAfterTheWave) {
  const TrialIndexKernel cpu;
  constexpr int kSub = mcm_internal::kSubBatch;
  const std::int64_t block = 4096;  // max(4096, M / 8)
  auto run = [&](const mcm_internal::GpuTrialKernel& gpu, std::int64_t first, int n) {
    mcm_internal::Scratch scratch;
    std::vector<double> outputs(static_cast<std::size_t>(kSub));
    gpu.Run(mcm_internal::KeyedStream(1), first, n, scratch, outputs.data());
    for (int i = 0; i < n; ++i) EXPECT_EQ(outputs[static_cast<std::size_t>(i)], first + i);
  };
  {
    SCOPED_TRACE("a fixed M of 3 blocks and 100 trials");
    auto owned = std::make_unique<GatedBlocks>();
    GatedBlocks& device = *owned;
    for (std::int64_t b = 0; b < 4; ++b) device.Open(static_cast<std::uint64_t>(b * block));
    const std::int64_t m = 3 * block + 100;
    const mcm_internal::GpuTrialKernel gpu(cpu, 1, std::move(owned), {}, m, /*fall_back=*/false);
    for (std::int64_t first = 0; first < m; first += kSub) {
      run(gpu, first, static_cast<int>(std::min<std::int64_t>(kSub, m - first)));
    }
    EXPECT_EQ(gpu.BlocksHeld(), 1u);  // the last: 3996 of its trials are past M
    gpu.TrialsRunBefore(m);
    EXPECT_EQ(gpu.BlocksHeld(), 0u);
    EXPECT_EQ(device.Computed(), (std::vector<std::uint64_t>{0, 4096, 8192, 12288}));
  }
  {
    SCOPED_TRACE("a rank's share: every other sub-batch of two blocks");
    auto owned = std::make_unique<GatedBlocks>();
    GatedBlocks& device = *owned;
    for (std::int64_t b = 0; b < 2; ++b) device.Open(static_cast<std::uint64_t>(b * block));
    const mcm_internal::GpuTrialKernel gpu(cpu, 1, std::move(owned), {}, 8 * block, /*fall_back=*/false);
    for (std::int64_t first = 0; first < 2 * block; first += 2 * kSub) run(gpu, first, kSub);
    EXPECT_EQ(gpu.BlocksHeld(), 2u);
    gpu.TrialsRunBefore(block + kSub);  // a wave that ends inside block 1
    EXPECT_EQ(gpu.BlocksHeld(), 1u);
    gpu.TrialsRunBefore(2 * block);
    EXPECT_EQ(gpu.BlocksHeld(), 0u);
    EXPECT_EQ(device.Computed(), (std::vector<std::uint64_t>{0, 4096}));
  }
}

// A forgotten block's buffer is the next block's (mcm/gpu_run.cc BlockBuffers): one thread asking
// for 8 blocks' trials in order allocates one buffer, and every trial's value is its own (the
// device writes every value of the buffer it is given again).
TEST(GpuPath, AForgottenBlocksBufferIsUsedByTheNext) {
  const TrialIndexKernel cpu;
  constexpr int kSub = mcm_internal::kSubBatch;
  const std::int64_t block = 4096, m = 8 * block;  // max(4096, M / 8)
  auto owned = std::make_unique<GatedBlocks>();
  GatedBlocks& device = *owned;
  for (std::int64_t b = 0; b < 8; ++b) device.Open(static_cast<std::uint64_t>(b * block));
  const mcm_internal::GpuTrialKernel gpu(cpu, 1, std::move(owned), {}, m, /*fall_back=*/false);
  mcm_internal::Scratch scratch;
  std::vector<double> outputs(static_cast<std::size_t>(kSub));
  for (std::int64_t first = 0; first < m; first += kSub) {
    gpu.Run(mcm_internal::KeyedStream(1), first, kSub, scratch, outputs.data());
    for (int i = 0; i < kSub; ++i) ASSERT_EQ(outputs[static_cast<std::size_t>(i)], first + i);
  }
  EXPECT_EQ(device.Computed().size(), 8u);
  EXPECT_EQ(gpu.BuffersAllocated(), 1);
}

// The engine tells the kernel when each wave's trials are all run: ends that grow, the last M.
TEST(GpuPath, TheEngineSaysWhenTheTrialsOfEachWaveAreRun) {
  for (int threads : {1, 2}) {
    SCOPED_TRACE(::testing::Message() << threads << " thread(s)");
    const TrialIndexKernel kernel;
    mcm_internal::OutputSpec spec;
    spec.names = {"y"};
    spec.units = {"m"};
    McmSettings settings;
    settings.trials = 123457;
    settings.num_threads = threads;
    settings.quiet = true;
    settings.device = McmDevice::kCpu;
    mcm_internal::RunEngine(kernel, spec, settings);
    ASSERT_FALSE(kernel.ends.empty());
    EXPECT_TRUE(std::is_sorted(kernel.ends.begin(), kernel.ends.end()));
    EXPECT_EQ(std::adjacent_find(kernel.ends.begin(), kernel.ends.end()), kernel.ends.end());
    EXPECT_GT(kernel.ends.front(), 0);
    EXPECT_EQ(kernel.ends.back(), settings.trials);
  }
}

// A device that fails at its third block (its first call is the run-time check): under "auto" the
// trials from there on run on the CPU, the files are the CPU's and the note says so; under "gpu"
// the run fails. With blocks whose preparation several threads share (the stages and drawn
// parameters of kGpuJobWithCpuDrawnParameters, 3 threads).
class FailsAtTheThirdBlock final : public gpu_internal::TrialsBackend {
 public:
  explicit FailsAtTheThirdBlock(const gpu_internal::TrialsJob& trials) : host_(gpu_internal::HostBackend(trials)) {}
  void Compute(std::uint64_t first, int n, const gpu_internal::PreparedTrials& prepared, double* values) override {
    if (++calls_ == 4) throw std::runtime_error("GPU: the device fell off the bus");
    host_->Compute(first, n, prepared, values);
  }
  std::string Description() const override { return "a failing GPU"; }

 private:
  std::unique_ptr<gpu_internal::TrialsBackend> host_;
  std::atomic<int> calls_{0};
};

TEST(GpuPath, AGpuThatFailsDuringTheRunLeavesTheRestToTheCpu) {
  Job job = ParseJob(kGpuJobWithCpuDrawnParameters, "gpu-cpu-drawn.toml", ".");
  job.map.reset();
  job.monte_carlo.trials = 50000;  // blocks of 6250 trials: the run needs 8
  RunOptions cpu;
  cpu.threads = 3;
  cpu.device = McmDevice::kCpu;
  const std::map<std::string, std::string> on_cpu = FilesOf(RunJob(job, cpu));
  gpu_internal::SetBackendForTest([](const gpu_internal::TrialsJob& trials, std::string*) {
    return std::make_unique<FailsAtTheThirdBlock>(trials);
  });
  RunOptions automatic = cpu;
  automatic.device = McmDevice::kAuto;
  const Results r = RunJob(job, automatic);
  EXPECT_EQ(r.mcm.device, "gpu: a failing GPU");
  EXPECT_NE(r.mcm.device_note.find("the GPU failed during the run (GPU: the device fell off the bus)"),
            std::string::npos)
      << r.mcm.device_note;
  std::map<std::string, std::string> on_gpu = FilesOf(r);
  for (const char* name : {"points.csv", "points.jsonl", "budget.csv", "tasks.csv"}) {
    EXPECT_TRUE(on_cpu.at(name) == on_gpu[name]) << name << " differs";
  }
  RunOptions gpu = cpu;
  gpu.device = McmDevice::kGpu;
  EXPECT_THROW(RunJob(job, gpu), std::exception);
  gpu_internal::SetBackendForTest(nullptr);
}

// The kernel draws the tracker's parameters itself where each is normal or fixed and correlated
// with no other input (stage inputs correlated among themselves included); otherwise the CPU
// draws them all for it (PointTrialsJob::params_drawn) and the run is the CPU's all the same
// (TheSameFilesAsTheCpuWithTheKernelOnTheHost covers kGpuJobWithCpuDrawnParameters).
TEST(GpuPath, TheCpuDrawsTheParametersOnlyWhereTheKernelCannot) {
  const std::string part = R"(
[part]
cte = "11.5 ppm/K"
temperature = { estimate = "21 degC", u = "0.3 K" }
)";
  const std::string environment = R"(
[environment]
temperature = { estimate = "20.5 degC", u = "0.2 K" }
pressure = { estimate = "1013.25 hPa", u = "0.3 hPa" }
humidity = { estimate = "45 %", u = "5 %" }
)";
  struct Case {
    std::string what, toml;
    int params_drawn;
  };
  const std::vector<Case> cases = {
      {"normal parameters", kGpuJob, 0},
      {"every stage, its humidity rectangular", kGpuJobWithStages, 0},
      {"stage inputs correlated among themselves", std::string(kGpuJob) + environment + part + R"(
[correlations.room]
inputs = ["thermal.temperature", "environment.temperature"]
matrix = [[1, 0.8], [0.8, 1]]
)", 0},
      {"a fixed parameter that is not normal (no draw)", std::string(kGpuJob) + R"(
[tracker.parameters.a0]
distribution = "rectangular"
u = "0 arcsec"
)", 0},
      {"a rectangular parameter", std::string(kGpuJob) + R"(
[tracker.parameters.a0]
distribution = "rectangular"
)", 1},
      {"a parameter correlated with the part's temperature", std::string(kGpuJob) + part + R"(
[correlations.thermometer]
inputs = ["thermal.temperature", "R0"]
matrix = [[1, 0.5], [0.5, 1]]
)", 1},
      {"every kind at once", kGpuJobWithCpuDrawnParameters, 1},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    Job job = ParseJob(c.toml, "drawn.toml", ".");
    job.map.reset();
    int params_drawn = -1;
    gpu_internal::SetBackendForTest([&params_drawn](const gpu_internal::TrialsJob& trials, std::string*) {
      params_drawn = trials.job.params_drawn;
      return gpu_internal::HostBackend(trials);
    });
    RunOptions options;
    options.trials = 2000;
    options.device = McmDevice::kGpu;
    const Results r = RunJob(job, options);
    gpu_internal::SetBackendForTest(nullptr);
    EXPECT_EQ(r.mcm.device.rfind("gpu: host", 0), 0u) << r.mcm.device;
    EXPECT_EQ(params_drawn, c.params_drawn);
  }
}

// On a machine with a working GPU (a lent one: scripts/device-check.sh): the GPU's files are the
// CPU's. Reports skipped, not passed, elsewhere.
TEST(GpuPath, OnARealGpuTheSameFilesAsTheCpu) {
  gpu_internal::TrialsJob probe;
  probe.model = "mirror";
  probe.job.num_params = 20;
  std::string why_not;
  if (gpu_internal::CudaBackend(probe, &why_not) == nullptr) GTEST_SKIP() << "no GPU: " << why_not;
  for (const Job& job : GpuPathJobs()) {
    SCOPED_TRACE(job.file);
    RunOptions cpu;
    cpu.device = McmDevice::kCpu;
    RunOptions gpu;
    gpu.device = McmDevice::kGpu;
    const Results on_cpu = RunJob(job, cpu), on_gpu = RunJob(job, gpu);
    EXPECT_EQ(on_gpu.mcm.device.rfind("gpu: ", 0), 0u);
    std::map<std::string, std::string> a = FilesOf(on_cpu), b = FilesOf(on_gpu);
    for (const char* name : {"points.csv", "points.jsonl", "budget.csv", "tasks.csv", "map.csv"}) {
      EXPECT_TRUE(a[name] == b[name]) << name << " differs between the CPU and " << on_gpu.mcm.device;
    }
  }
}

}  // namespace
}  // namespace vlt
