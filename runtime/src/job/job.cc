// job/job.cc — job file (TOML) -> vlt::Job: ParseJob calls the section readers of job_detail.h
// (instrument.cc, points.cc, tasks.cc, settings.cc) in order. The keys and their units are
// documented in docs/job-file.md; keep the two in step. Every table is read through a Section that remembers which keys were
// used, so that a misspelt key is an error instead of a silently ignored input.
#include "vlt/job.h"

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <functional>
#include <sstream>
#include <string_view>
#include <tuple>
#include <utility>

#include <Eigen/Geometry>
#include <toml++/toml.h>

#include "job/job_detail.h"
#include "vlt/calibration.h"
#include "vlt/error.h"

namespace vlt {

std::vector<std::string> Job::point_names() const {
  std::vector<std::string> names;
  names.reserve(points.size());
  for (const JobPoint& p : points) names.push_back(p.name);
  return names;
}

using namespace base_internal;
using namespace instrument_internal;
using namespace job_internal;  // Section, AsString and the section readers

namespace {

// The first point (in the job's order) whose name an earlier point has, or -1 — what inserting
// every name into a set in order finds, without a set of 10^6 strings (a scan's plan: 0.24 s of
// allocations and comparisons): the names' hashes with their indices sorted, then, among the
// points of one hash, the same name next to each other (by name, then index), so that the second
// of each name is its first repeat; the smallest such index over all names.
std::ptrdiff_t FirstRepeatedName(const std::vector<JobPoint>& points) {
  std::vector<std::pair<std::size_t, std::uint32_t>> keyed(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    keyed[i] = {std::hash<std::string_view>{}(points[i].name), static_cast<std::uint32_t>(i)};
  }
  std::sort(keyed.begin(), keyed.end());
  std::ptrdiff_t first = -1;
  for (std::size_t begin = 0; begin < keyed.size();) {
    std::size_t end = begin + 1;
    while (end < keyed.size() && keyed[end].first == keyed[begin].first) ++end;
    if (end - begin > 1) {
      std::vector<std::uint32_t> same(end - begin);
      for (std::size_t k = begin; k < end; ++k) same[k - begin] = keyed[k].second;
      std::sort(same.begin(), same.end(), [&](std::uint32_t a, std::uint32_t b) {
        return std::tie(points[a].name, a) < std::tie(points[b].name, b);
      });
      for (std::size_t k = 1; k < same.size(); ++k) {
        if (points[same[k]].name == points[same[k - 1]].name &&
            (k < 2 || points[same[k - 1]].name != points[same[k - 2]].name) &&
            (first < 0 || same[k] < first)) {
          first = same[k];
        }
      }
    }
    begin = end;
  }
  return first;
}

}  // namespace

Eigen::Vector3d PartToTrackerNominal(const MeasurementSetup& setup, const Eigen::Vector3d& part) {
  Eigen::Vector3d x = part;
  if (setup.thermal) {
    x *= 1.0 + setup.thermal->cte.estimate * (setup.thermal->temperature.estimate - setup.thermal->reference);
  }
  if (setup.pose) {
    const StationPose& p = *setup.pose;
    Eigen::Matrix3d r = (Eigen::AngleAxisd(p.rz.estimate, Eigen::Vector3d::UnitZ()) *
                         Eigen::AngleAxisd(p.ry.estimate, Eigen::Vector3d::UnitY()) *
                         Eigen::AngleAxisd(p.rx.estimate, Eigen::Vector3d::UnitX()))
                            .toRotationMatrix();
    Eigen::Vector3d t(p.tx.estimate, p.ty.estimate, p.tz.estimate);
    x = r.transpose() * (x - t);
  }
  return x;
}

Job ParseJob(std::string_view text, const std::string& file, const std::filesystem::path& base_dir,
             const JobOverrides& overrides) {
  toml::table root = ParseToml(text, file);
  Job job;
  job.file = file;
  job.base_dir = base_dir;
  job.name = std::filesystem::path(file).stem().string();
  job.input_files.push_back({"job", file, Sha256Bytes(text)});
  Section top(root, file, "");
  top.set_hint(
      "job, tracker, environment, station, part, correlations, plan, readings, task, nominal, alignment, "
      "deviation, profile, monte_carlo, map, optimize, output");

  ReadJobMeta(top, job.name, &job.description, job.name, &job.record);
  ReadTracker(top, job, overrides.calibration ? &*overrides.calibration : nullptr);
  ReadEnvironment(top, job);
  ReadStation(top, job);
  ReadPart(top, job);
  ReadCorrelations(top, job);

  // [monte_carlo] before the points: its threads (or --threads) read a scan's plan.
  ReadMonteCarlo(top, job.monte_carlo);
  const int threads = overrides.threads.value_or(job.monte_carlo.threads);

  Section plan = top.Sub("plan", false);
  Section readings = top.Sub("readings", false);
  if (plan.exists() && readings.exists()) {
    throw InputError(file + ": readings: give either [plan] (offline) or [readings] (online), not both");
  }
  if (plan.exists()) {
    job.mode = JobMode::kPlan;
    ReadPlan(plan, job, true, threads);
  } else if (readings.exists()) {
    job.mode = JobMode::kReadings;
    ReadReadings(readings, job);
  } else {
    throw InputError(file + ": plan: required key is missing (give [plan] points, or [readings] from a CSV)");
  }
  if (const std::ptrdiff_t repeat = FirstRepeatedName(job.points); repeat >= 0) {
    const JobPoint& p = job.points[static_cast<std::size_t>(repeat)];
    throw InputError(p.where + ": point name '" + p.name + "' used twice");
  }
  ReadTasks(top, job);
  ReadAlignments(top, job);
  ReadMap(top, job);
  ReadOptimize(top, job);
  ReadOutput(top, job.output, /*point_files=*/true);
  top.Finish();
  return job;
}

Job LoadJob(const std::string& path, const JobOverrides& overrides) {
  const std::string text = ReadTextFile(path, "the job file");
  return ParseJob(text, path, BaseDirectory(path), overrides);
}

}  // namespace vlt
