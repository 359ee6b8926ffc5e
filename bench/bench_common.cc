// The plan and setups shared by the benchmarks (bench_common.h).
#include "bench_common.h"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "vlt/gum.h"
#include "vlt/models.h"

namespace vlt::bench {

std::vector<Eigen::Vector3d> PanelPoints(std::size_t n) {
  // Columns along x (4 m), rows along y (1.5 m): nx / ny ~ 4 / 1.5.
  const std::size_t nx = std::max<std::size_t>(
      1, static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(n) * 4.0 / 1.5))));
  const std::size_t ny = std::max<std::size_t>(1, (n + nx - 1) / nx);
  std::vector<Eigen::Vector3d> points;
  points.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t ix = i % nx, iy = i / nx;
    const double x = nx > 1 ? 3.0 + 4.0 * static_cast<double>(ix) / static_cast<double>(nx - 1) : 5.0;
    const double y = ny > 1 ? -0.75 + 1.5 * static_cast<double>(iy) / static_cast<double>(ny - 1) : 0.0;
    points.emplace_back(x, y, -0.8);
  }
  return points;
}

std::vector<Eigen::Vector3d> PanelReadings(const MeasurementModel& model, std::size_t n) {
  std::vector<Eigen::Vector3d> readings;
  readings.reserve(n);
  for (const Eigen::Vector3d& p : PanelPoints(n)) readings.push_back(ReadingsForPartPoint(model, p));
  return readings;
}

const ModelInfo& Model(const char* model_name) {
  const ModelInfo* model = FindModel(model_name);
  if (model == nullptr) throw std::runtime_error(std::string("no model ") + model_name);
  return *model;
}

std::vector<int> BannerSensitivityOps(const char* model_name) {
  std::ifstream in(std::string(VLT_SOURCE_DIR) + "/generated/" + model_name + ".h");
  std::vector<int> ops;
  std::string line;
  while (std::getline(in, line) && line.rfind("//", 0) == 0) {
    std::istringstream fields(line.substr(2));
    std::string kernel;
    int count = 0;
    if (fields >> kernel >> count && kernel.rfind("Sensitivity_", 0) == 0) ops.push_back(count);
  }
  return ops;
}

MeasurementSetup TrackerSetup(const char* model_name, bool environment) {
  MeasurementSetup setup;
  setup.model = &Model(model_name);
  for (int k = 0; k < setup.model->num_params; ++k) {
    const QuantityInfo& q = setup.model->params[k];
    UncertainInput in;
    in.name = q.name;
    in.unit = q.unit;
    in.group = "parameter";
    in.estimate = q.default_estimate;
    in.u = q.default_u;
    in.distribution = q.default_distribution;
    in.shape = q.default_shape;
    setup.params.push_back(in);
  }
  setup.noise.range_a = kRangeA;
  setup.noise.range_b = kRangeB;
  setup.noise.azimuth = kAngleU;
  setup.noise.elevation = kAngleU;
  if (environment) {
    Environment env;
    env.equation = Environment::Equation::kCiddor;
    env.vacuum_wavelength = 633e-9;
    env.temperature.estimate = 20.5;
    env.temperature.u = 0.2;
    env.pressure.estimate = 101325.0;
    env.pressure.u = 30.0;
    env.humidity.estimate = 45.0;
    env.humidity.u = 5.0;
    env.humidity.distribution = "rectangular";
    env.co2.estimate = 450e-6;
    env.co2.u = 30e-6;
    setup.environment = env;
  }
  return setup;
}

}  // namespace vlt::bench
