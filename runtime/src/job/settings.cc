// job/settings.cc — the run settings of a job file: [monte_carlo], [map], [output].
// Keys: docs/job-file.md.
#include <cmath>
#include <sstream>

#include <toml++/toml.h>

#include "job/job_detail.h"
#include "base/shared_settings.h"
#include "vlt/error.h"
#include "vlt/job.h"
#include "vlt/units.h"

namespace vlt {

McmDevice McmDeviceNamed(std::string_view name, const std::string& where) {
  if (name == "auto") return McmDevice::kAuto;
  if (name == "cpu") return McmDevice::kCpu;
  if (name == "gpu") return McmDevice::kGpu;
  throw InputError(where + ": '" + std::string(name) + "': expected \"auto\", \"cpu\" or \"gpu\"");
}

}  // namespace vlt

namespace vlt::job_internal {

void ReadMonteCarlo(Section& top, MonteCarloSettings& mc) {
  Section s = top.Sub("monte_carlo", false);
  if (!s.exists()) return;
  s.set_hint("enabled, trials, adaptive, n_dig, seed, coverage_probability, threads, device");
  if (const toml::node* n = s.Get("enabled")) mc.enabled = AsBool(*n, s.Where("enabled"));
  if (const toml::node* n = s.Get("adaptive")) mc.adaptive = AsBool(*n, s.Where("adaptive"));
  ReadCoverageProbability(s, "coverage_probability", mc.coverage_probability);
  // JCGM 101 7.2.2: M should be large compared with 1/(1-p); at least 100/(1-p).
  const double minimum = std::ceil(100.0 / (1.0 - mc.coverage_probability));
  ReadTrials(s, "trials", static_cast<std::int64_t>(minimum), 1000000000LL,
             " for coverage probability " + std::to_string(mc.coverage_probability) +
                 " (JCGM 101 7.2.2: M >= 100/(1-p))",
             mc.trials);
  if (const toml::node* n = s.Get("n_dig")) {
    std::int64_t v = AsInteger(*n, s.Where("n_dig"));
    if (v != 1 && v != 2) throw InputError(s.Where("n_dig") + ": must be 1 or 2 (JCGM 101 7.9.2)");
    mc.n_dig = static_cast<int>(v);
  }
  ReadSeed(s, "seed", mc.seed);
  ReadThreads(s, "threads", mc.threads);
  if (const toml::node* n = s.Get("device")) mc.device = McmDeviceNamed(AsString(*n, s.Where("device")), s.Where("device"));
  s.Finish();
}

std::string ExtentString(const toml::node& node, const std::string& where) {
  if (node.is_string()) return *node.value<std::string>();
  if (!node.is_array()) throw InputError(where + ": expected \"a,b,c,d\" or an array of quantities");
  std::string out;
  for (const toml::node& e : *node.as_array()) {
    if (!out.empty()) out += ",";
    if (e.is_string())
      out += *e.value<std::string>();
    else {
      std::ostringstream os;
      os.precision(17);
      os << AsNumber(e, where);
      out += os.str();
    }
  }
  return out;
}

std::vector<double> LengthList(const toml::node& node, std::size_t count, const std::string& where) {
  const std::string text =
      node.is_string() || node.is_array() ? ExtentString(node, where) : std::to_string(AsNumber(node, where));
  std::vector<double> values;
  std::string part;
  for (std::size_t i = 0; i <= text.size(); ++i) {
    if (i == text.size() || text[i] == ',') {
      values.push_back(ParseQuantity(part, Dimension::kLength, where));
      part.clear();
    } else {
      part += text[i];
    }
  }
  if (values.size() != count) {
    throw InputError(where + ": expected " + std::to_string(count) + " comma-separated lengths, got " +
                     std::to_string(values.size()));
  }
  return values;
}

void ReadMap(Section& top, Job& job) {
  Section s = top.Sub("map", false);
  if (!s.exists()) return;
  s.set_hint("plane, extent, box, step, monte_carlo");
  const toml::node* plane = s.Get("plane");
  const toml::node* extent = s.Get("extent");
  const toml::node* box = s.Get("box");
  const toml::node* step = s.Get("step");
  std::string step_text = "0.25 m";
  if (step)
    step_text = step->is_string() ? *step->value<std::string>() : ExtentString(*step, s.Where("step"));
  if (plane && box) throw InputError(s.Where("box") + ": give either plane + extent or box, not both");
  if (plane) {
    if (!extent) throw InputError(s.Where("extent") + ": required key is missing (with plane)");
    job.map = ParseMapPlane(AsString(*plane, s.Where("plane")), ExtentString(*extent, s.Where("extent")),
                            step_text, s.WhereSelf());
  } else if (box) {
    if (extent) throw InputError(s.Where("extent") + ": extent goes with plane, not with box");
    job.map = ParseMapBox(ExtentString(*box, s.Where("box")), step_text, s.WhereSelf());
  } else {
    throw InputError(s.Where("plane") + ": required key is missing (plane + extent, or box)");
  }
  if (const toml::node* n = s.Get("monte_carlo")) job.map->monte_carlo = AsBool(*n, s.Where("monte_carlo"));
  s.Finish();
}

void ReadOutput(Section& top, OutputSettings& output, bool point_files) {
  Section s = top.Sub("output", false);
  if (!s.exists()) return;
  s.set_hint(point_files ? "directory, ellipsoid_scale, detail, arrays" : "directory, ellipsoid_scale");
  if (const toml::node* n = s.Get("directory")) output.directory = AsString(*n, s.Where("directory"));
  if (const toml::node* n = s.Get("ellipsoid_scale")) {
    output.ellipsoid_scale = AsNumber(*n, s.Where("ellipsoid_scale"));
    if (!(output.ellipsoid_scale > 0)) throw InputError(s.Where("ellipsoid_scale") + ": must be positive");
  }
  if (!point_files) {
    s.Finish();
    return;
  }
  if (const toml::node* n = s.Get("detail")) {
    const std::string detail = AsString(*n, s.Where("detail"));
    if (detail == "auto") {
      output.detail = PointDetail::kAuto;
    } else if (detail == "full") {
      output.detail = PointDetail::kFull;
    } else if (detail == "compact") {
      output.detail = PointDetail::kCompact;
    } else {
      throw InputError(s.Where("detail") + ": must be \"auto\", \"full\" or \"compact\"");
    }
  }
  if (const toml::node* n = s.Get("arrays")) output.arrays = AsBool(*n, s.Where("arrays"));
  s.Finish();
}

}  // namespace vlt::job_internal
