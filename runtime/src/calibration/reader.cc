// calibration/reader.cc — the files of the calibration loop (vlt/calibration.h): test layouts, the
// input of `vlt test` and the input of `vlt calibrate`. They reuse the job's section readers
// ([tracker], [readings]) so that a tracker and its readings are written the same way everywhere.
// Keys, units and defaults: docs/calibration.md.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

#include <toml++/toml.h>

#include "job/job_detail.h"
#include "base/shared_settings.h"
#include "vlt/calibration.h"
#include "vlt/error.h"
#include "vlt/input_file.h"
#include "vlt/job_record.h"
#include "vlt/units.h"

namespace vlt {

using namespace base_internal;
using namespace instrument_internal;
using namespace job_internal;  // Section, AsString and the section readers

namespace {

double Positive(Section& s, std::string_view key, Dimension dim) {
  const double v = AsQuantity(s.Require(key), dim, s.Where(key));
  if (!(v > 0.0) || !std::isfinite(v)) throw InputError(s.Where(key) + ": must be positive");
  return v;
}

double Optional(Section& s, std::string_view key, Dimension dim, double fallback) {
  const toml::node* n = s.Get(key);
  return n ? AsQuantity(*n, dim, s.Where(key)) : fallback;
}

Face ReadFace(Section& s) {
  const toml::node* n = s.Get("face");
  if (!n) return Face::kFront;
  const std::string text = AsString(*n, s.Where("face"));
  return ParseFace(text.c_str(), s.Where("face").c_str());
}

// Position of a layout entry: horizontal distance from the standing axis, azimuth, height.
// Returns the centre and the unit vectors radial r, transverse t (toward increasing azimuth), up z.
struct Place {
  Eigen::Vector3d centre, radial, transverse, up;
};
// Within a tracker's reach (kMaxRange, as a job's points) and an azimuth within 720 degrees either
// way (as a reading's: beyond, a double has few digits left below a turn).
Place ReadPlace(Section& s, double distance) {
  const double azimuth = Optional(s, "azimuth", Dimension::kAngle, 0.0);
  const double height = Optional(s, "height", Dimension::kLength, 0.0);
  if (!(std::abs(azimuth) <= 4.0 * std::numbers::pi))
    throw InputError(s.Where("azimuth") + ": beyond 720 degrees either way");
  Place p;
  p.radial = Eigen::Vector3d(std::cos(azimuth), std::sin(azimuth), 0.0);
  p.transverse = Eigen::Vector3d(-std::sin(azimuth), std::cos(azimuth), 0.0);
  p.up = Eigen::Vector3d::UnitZ();
  p.centre = distance * p.radial + height * p.up;
  if (!(p.centre.norm() <= kMaxRange)) {
    throw InputError(s.WhereSelf() + ": " + FormatQuantity(p.centre.norm(), Dimension::kLength, "m", 6) +
                     " from the tracker: beyond any laser tracker (at most " +
                     FormatQuantity(kMaxRange, Dimension::kLength, "km", 3) + ")");
  }
  return p;
}

// "a + b" MPE or length-plus-ratio strings.
Mpe ReadMpe(Section& s, std::string_view key) {
  Mpe mpe;
  if (const toml::node* n = s.Get(key)) {
    ParseLengthPlusRatio(AsString(*n, s.Where(key)), s.Where(key), mpe.a, mpe.b);
    mpe.set = true;
  }
  return mpe;
}

// [tests] layout (a path relative to the file) and mpe.
void ReadLayoutAndMpe(Section& tests, const std::filesystem::path& base_dir, TestLayout& layout,
                      TestSettings& settings) {
  const std::string file = AsString(tests.Require("layout"), tests.Where("layout"));
  const std::filesystem::path layout_path = base_dir / file;
  if (const std::string problem = InputFileProblem(layout_path.string()); !problem.empty()) {
    throw InputError(tests.Where("layout") + ": cannot read '" + layout_path.string() + "': " + problem);
  }
  layout = LoadTestLayout(layout_path.string());
  Section mpe = tests.Sub("mpe", false);
  if (mpe.exists()) {
    mpe.set_hint("length, ranging, two_face");
    settings.length = ReadMpe(mpe, "length");
    settings.ranging = ReadMpe(mpe, "ranging");
    settings.two_face = ReadMpe(mpe, "two_face");
    mpe.Finish();
  }
}

}  // namespace

TestLayout LoadTestLayout(const std::string& path) {
  const std::string text = ReadTextFile(path, "the test layout");
  toml::table root = ParseToml(text, path);
  Section top(root, path, "");
  top.set_hint("layout, bar, length, ranging, two_face");
  TestLayout layout;
  layout.where = path;
  Section meta = top.Sub("layout", true);
  meta.set_hint("name, source");
  layout.name = AsString(meta.Require("name"), meta.Where("name"));
  if (const toml::node* n = meta.Get("source")) layout.source = AsString(*n, meta.Where("source"));
  meta.Finish();
  std::set<std::string> names;
  auto unique = [&](Section& s) {
    std::string name = AsString(s.Require("name"), s.Where("name"));
    CheckName(name, s.Where("name"), "bar or test");
    if (name.find_first_of(",\"\n") != std::string::npos)
      throw InputError(s.Where("name") + ": a name may not contain ',', '\"' or a line break");
    if (!names.insert(name).second) throw InputError(s.Where("name") + ": '" + name + "' is used twice");
    return name;
  };
  ForEachTable(top, path, "bar", [&](Section& s) {
    s.set_hint("name, length, u, u_position");
    ReferenceBar bar;
    bar.name = unique(s);
    bar.length = Positive(s, "length", Dimension::kLength);
    if (!(bar.length <= kMaxRange)) throw InputError(s.Where("length") + ": longer than a tracker's reach (10 km)");
    bar.u = Positive(s, "u", Dimension::kLength);
    bar.u_position = Positive(s, "u_position", Dimension::kLength);
    bar.where = s.WhereSelf();
    layout.bars.push_back(bar);
  });
  ForEachTable(top, path, "length", [&](Section& s) {
    s.set_hint("name, bar, distance, azimuth, height, orientation, face");
    StandardTest t;
    t.kind = TestKind::kLength;
    t.name = unique(s);
    t.where = s.WhereSelf();
    t.bar = AsString(s.Require("bar"), s.Where("bar"));
    const ReferenceBar* bar = nullptr;
    for (const ReferenceBar& b : layout.bars) {
      if (b.name == t.bar) bar = &b;
    }
    if (!bar)
      throw InputError(s.Where("bar") + ": bar '" + t.bar +
                       "' is not defined (define [[bar]] before the tests)");
    const Place p = ReadPlace(s, Positive(s, "distance", Dimension::kLength));
    const std::string orientation = AsString(s.Require("orientation"), s.Where("orientation"));
    Eigen::Vector3d axis;
    if (orientation == "horizontal")
      axis = p.transverse;
    else if (orientation == "vertical")
      axis = p.up;
    else if (orientation == "right_diagonal")
      axis = (-p.transverse + p.up).normalized();
    else if (orientation == "left_diagonal")
      axis = (p.transverse + p.up).normalized();
    else if (orientation == "radial")
      axis = p.radial;
    else
      throw InputError(s.Where("orientation") + ": '" + orientation +
                       "' (expected horizontal, vertical, right_diagonal, left_diagonal or radial)");
    t.a = p.centre - 0.5 * bar->length * axis;
    t.b = p.centre + 0.5 * bar->length * axis;
    t.face = ReadFace(s);
    layout.tests.push_back(t);
  });
  ForEachTable(top, path, "ranging", [&](Section& s) {
    s.set_hint("name, home, distance, azimuth, height, u, face");
    StandardTest t;
    t.kind = TestKind::kRanging;
    t.name = unique(s);
    t.where = s.WhereSelf();
    const double home = Positive(s, "home", Dimension::kLength);
    const double distance = Positive(s, "distance", Dimension::kLength);
    if (distance == home) throw InputError(s.Where("distance") + ": equals home");
    const Place p = ReadPlace(s, home);
    t.a = p.centre;
    t.b = p.centre + (distance - home) * p.radial;
    t.reference_u = Positive(s, "u", Dimension::kLength);
    t.face = ReadFace(s);
    layout.tests.push_back(t);
  });
  ForEachTable(top, path, "two_face", [&](Section& s) {
    s.set_hint("name, distance, azimuth, height");
    StandardTest t;
    t.kind = TestKind::kTwoFace;
    t.name = unique(s);
    t.where = s.WhereSelf();
    t.a = ReadPlace(s, Positive(s, "distance", Dimension::kLength)).centre;
    t.b = t.a;
    layout.tests.push_back(t);
  });
  top.Finish();
  if (layout.tests.empty())
    throw InputError(path + ": length: the layout has no tests ([[length]], [[ranging]], [[two_face]])");
  return layout;
}

TestJob LoadTestJob(const std::string& path) {
  const std::string text = ReadTextFile(path, "the test file");
  toml::table root = ParseToml(text, path);
  Section top(root, path, "");
  top.set_hint("job, tracker, tests");
  TestJob job;
  job.file = path;
  job.name = std::filesystem::path(path).stem().string();
  ReadJobMeta(top, job.name, nullptr, job.name);
  Job holder;  // the job's [tracker] reader fills a Job
  holder.file = path;
  holder.base_dir = BaseDirectory(path);
  ReadTracker(top, holder);
  SharedCorrelation(SharedInputNames(holder.setup), holder.setup.correlations);  // checks the groups
  job.tracker = holder.setup;
  job.warnings = holder.warnings;
  Section tests = top.Sub("tests", true);
  tests.set_hint("layout, mpe, coverage_probability, simulate");
  ReadLayoutAndMpe(tests, holder.base_dir, job.layout, job.settings);
  ReadCoverageProbability(tests, "coverage_probability", job.settings.coverage_probability);
  Section sim = tests.Sub("simulate", false);
  if (sim.exists()) {
    sim.set_hint("seed");
    job.simulate = true;
    ReadSeed(sim, "seed", job.seed);
    sim.Finish();
  }
  tests.Finish();
  top.Finish();
  return job;
}

// A datasheet's statement as a test file (docs/profiles.md): [job] (name, [job.instrument]),
// [tracker] (model, noise; parameters only as u, the generic values the bound scales), [tests]
// (layout, mpe), [prior] (conformance_probability, bound, [prior.source]).
PriorJob LoadPriorJob(const std::string& path) {
  const std::string text = ReadTextFile(path, "the profile");
  toml::table root = ParseToml(text, path);
  Section top(root, path, "");
  top.set_hint("job, tracker, tests, prior");
  PriorJob job;
  job.file = path;
  JobRecord record;
  ReadJobMeta(top, job.name, nullptr, std::filesystem::path(path).stem().string(), &record);
  job.instrument = DescribeInstrument(record.instrument);
  Job holder;
  holder.file = path;
  holder.base_dir = BaseDirectory(path);
  ReadTracker(top, holder);
  if (holder.calibration) {
    throw InputError(path + ": tracker.calibration: a profile derives priors from a datasheet; it loads no calibration");
  }
  job.tracker = holder.setup;
  job.warnings = holder.warnings;
  const ModelInfo& model = *job.tracker.model;
  for (int k = 0; k < model.num_params; ++k) {
    // The prior's mean is the tracker's compensation: a profile states how uncertain the
    // parameters are, not an error state (that is `vlt test`'s).
    if (job.tracker.params[k].estimate != model.params[k].default_estimate) {
      throw InputError(path + ": tracker.parameters." + model.params[k].name +
                       ": a profile gives only u (e.g. { estimate = \"0 um\", u = \"5 um\" }): the prior's "
                       "estimate is the model's compensation");
    }
  }
  if (!job.tracker.correlations.empty()) {
    throw InputError(path + ": correlations: the prior from a datasheet is independent (docs/profiles.md)");
  }
  Section tests = top.Sub("tests", true);
  tests.set_hint("layout, mpe");
  ReadLayoutAndMpe(tests, holder.base_dir, job.layout, job.mpe);
  for (const auto& [kind, mpe] : {std::pair{"length", &job.mpe.length}, std::pair{"ranging", &job.mpe.ranging},
                                  std::pair{"two_face", &job.mpe.two_face}}) {
    if (mpe->set && mpe->a <= 0.0 && mpe->b <= 0.0)
      throw InputError(tests.Where("mpe") + "." + kind + ": an MPE of zero: no instrument meets it");
  }
  tests.Finish();
  if (!job.mpe.length.set && !job.mpe.ranging.set && !job.mpe.two_face.set)
    throw InputError(tests.Where("mpe") + ": a profile needs at least one MPE (length, ranging, two_face)");
  Section prior = top.Sub("prior", false);
  if (prior.exists()) {
    prior.set_hint("conformance_probability, bound, source");
    if (ReadCoverageProbability(prior, "conformance_probability", job.settings.conformance_probability) &&
        job.settings.conformance_probability < 0.5) {
      // An MPE met less often than not states no bound (and p -> 0 has no quantile to solve for).
      throw InputError(prior.Where("conformance_probability") +
                       ": an MPE statement's probability of conformance is at least 0.5 (e.g. 0.95; 0.6827 "
                       "for one standard deviation)");
    }
    if (const toml::node* n = prior.Get("bound")) {
      job.settings.bound = AsNumber(*n, prior.Where("bound"));
      if (!(job.settings.bound >= 1.0 && job.settings.bound <= 1000.0))
        throw InputError(prior.Where("bound") + ": expected a multiple of the generic u from 1 to 1000");
    }
    Section source = prior.Sub("source", false);
    if (source.exists()) {
      for (auto&& [key, node] : source.table()) {
        (void)node;
        const std::string name(key.str());
        // The key names the statement in prior.toml and the report: a plain word.
        const bool word = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
          return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
        });
        if (!word)
          throw InputError(source.WhereSelf() + ": a key of letters, digits, '_', '-' or '.' expected (it names a statement)");
        job.sources.emplace_back(name, RecordText(source, name));
      }
      source.Finish();
    }
    prior.Finish();
  }
  top.Finish();
  return job;
}

CalibrationJob LoadCalibrationJob(const std::string& path) {
  const std::string text = ReadTextFile(path, "the calibration job");
  toml::table root = ParseToml(text, path);
  Section top(root, path, "");
  top.set_hint("job, calibration, tracker, readings, bar, reference, output");
  CalibrationJob job;
  job.file = path;
  job.name = std::filesystem::path(path).stem().string();
  job.data_files.push_back(path);
  ReadJobMeta(top, job.name, nullptr, job.name);
  Job holder;
  holder.file = path;
  holder.base_dir = BaseDirectory(path);
  ReadTracker(top, holder);
  // A prior from a datasheet (vlt prior) is a prior; an identified calibration is not a start.
  if (holder.calibration && holder.calibration->kind != "prior from MPE") {
    throw InputError(path +
                     ": tracker.calibration: a calibration job estimates the parameters; start from priors "
                     "(the model's, [tracker.parameters] or a prior file of vlt prior), not from another "
                     "calibration");
  }
  Section readings = top.Sub("readings", true);
  ReadReadings(readings, holder);
  job.warnings = holder.warnings;
  job.data_files.push_back(holder.readings_file);

  CalibrationData& data = job.data;
  data.where = path;
  data.model = holder.setup.model;
  data.priors = holder.setup.params;
  // The priors' correlation: [tracker.correlations] (parameters only), checked and assembled by
  // SharedCorrelation as in a job.
  if (!holder.setup.correlations.empty()) {
    data.prior_correlation = SharedCorrelation(SharedInputNames(holder.setup), holder.setup.correlations);
  }
  data.noise = holder.setup.noise;
  for (const JobPoint& p : holder.points) {
    data.readings.push_back({p.name, p.face, p.readings, p.where, p.time, p.time_kind});
  }

  Section cal = top.Sub("calibration", false);
  if (cal.exists()) {
    cal.set_hint("instrument, fit, exclude, hold_ratio, outlier_limit, coverage_probability, max_iterations");
    if (const toml::node* n = cal.Get("instrument")) job.instrument = AsString(*n, cal.Where("instrument"));
    const toml::node* fit = cal.Get("fit");
    const toml::node* exclude = cal.Get("exclude");
    if (fit && exclude) throw InputError(cal.Where("exclude") + ": give either fit or exclude, not both");
    if (fit || exclude) {
      const std::string key = fit ? "fit" : "exclude";
      const toml::node& list = fit ? *fit : *exclude;
      if (!list.is_array()) throw InputError(cal.Where(key) + ": expected an array of parameter names");
      data.fit.assign(data.priors.size(), !fit);
      for (const toml::node& e : *list.as_array()) {
        const std::string name = AsString(e, cal.Where(key));
        std::size_t k = 0;
        while (k < data.priors.size() && data.priors[k].name != name) ++k;
        if (k == data.priors.size())
          throw InputError(cal.Where(key) + ": unknown parameter '" + name + "' of model '" +
                           data.model->name + "'");
        data.fit[k] = fit != nullptr;
      }
    }
    if (const toml::node* n = cal.Get("hold_ratio")) {
      job.options.hold_ratio = AsNumber(*n, cal.Where("hold_ratio"));
      if (!(job.options.hold_ratio > 0.0) || !std::isfinite(job.options.hold_ratio))
        throw InputError(cal.Where("hold_ratio") + ": must be positive");
    }
    ReadOutlierLimit(cal, "outlier_limit", job.options.outlier_limit);
    ReadCoverageProbability(cal, "coverage_probability", job.options.coverage_probability);
    ReadIterationLimit(cal, "max_iterations", job.options.max_iterations);
    cal.Finish();
  }
  ForEachTable(top, path, "bar", [&](Section& s) {
    s.set_hint("name, length, u, u_position, positions");
    ReferenceBar bar;
    bar.where = s.WhereSelf();
    bar.name = AsString(s.Require("name"), s.Where("name"));
    for (const ReferenceBar& other : data.bars) {
      if (other.name == bar.name)
        throw InputError(s.Where("name") + ": bar '" + bar.name + "' defined twice");
    }
    bar.length = Positive(s, "length", Dimension::kLength);
    if (!(bar.length <= kMaxRange)) throw InputError(s.Where("length") + ": longer than a tracker's reach (10 km)");
    bar.u = Positive(s, "u", Dimension::kLength);
    bar.u_position = Positive(s, "u_position", Dimension::kLength);
    const toml::node& positions = s.Require("positions");
    const std::string where = s.Where("positions");
    if (!positions.is_array() || positions.as_array()->empty())
      throw InputError(where + ": expected [[\"a\", \"b\"], ...] (target names of the two ends)");
    for (const toml::node& e : *positions.as_array()) {
      if (!e.is_array() || e.as_array()->size() != 2)
        throw InputError(where + ": each position is a pair [\"a\", \"b\"] of target names");
      bar.positions.emplace_back(AsString(*e.as_array()->get(0), where),
                                 AsString(*e.as_array()->get(1), where));
    }
    data.bars.push_back(bar);
  });
  ForEachTable(top, path, "reference", [&](Section& s) {
    s.set_hint("from, to, length, u");
    ReferenceDistance ref;
    ref.where = s.WhereSelf();
    ref.from = AsString(s.Require("from"), s.Where("from"));
    ref.to = AsString(s.Require("to"), s.Where("to"));
    ref.length = Positive(s, "length", Dimension::kLength);
    ref.u = Positive(s, "u", Dimension::kLength);
    data.distances.push_back(ref);
  });
  Section output = top.Sub("output", false);
  if (output.exists()) {
    output.set_hint("directory");
    if (const toml::node* n = output.Get("directory"))
      job.output_directory = AsString(*n, output.Where("directory"));
    output.Finish();
  }
  top.Finish();
  return job;
}

}  // namespace vlt
