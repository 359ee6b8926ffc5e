// job/job.cc — job file (TOML) -> vlt::Job: ParseJob calls the section readers of job_detail.h
// (instrument.cc, points.cc, tasks.cc, settings.cc) in order. The keys and their units are
// documented in docs/job-file.md; keep the two in step. Every table is read through a Section that remembers which keys were
// used, so that a misspelt key is an error instead of a silently ignored input.
#include "vlt/job.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <fstream>
#include <functional>
#include <span>
#include <sstream>
#include <string_view>
#include <tuple>
#include <utility>

#include <Eigen/Geometry>
#include <toml++/toml.h>

#include "job/job_detail.h"
#include "parallel/memory.h"
#include "parallel/pool.h"
#include "vlt/calibration.h"
#include "vlt/error.h"

namespace vlt {

std::vector<std::string> Job::point_names(int threads) const {
  std::vector<std::string> names;
  parallel_internal::ReserveMapped(names, points.size(), threads);
  names.resize(points.size());
  parallel_internal::ForEachChunk(names.size(), 8192, threads, [&](std::size_t, std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) names[i] = points[i].name;
  });
  return names;
}

using namespace base_internal;
using namespace instrument_internal;
using namespace job_internal;  // Section, AsString and the section readers

namespace {

using KeyedName = std::pair<std::size_t, std::uint32_t>;  // the name's hash, the point's index

// Among points sorted by (hash, index): the smallest index of a point whose name a point of lower
// index has, or -1. Among the points of one hash, the same name next to each other (by name,
// then index), so that the second of each name is its first repeat.
std::ptrdiff_t FirstRepeatAmong(std::span<const KeyedName> keyed, const std::vector<JobPoint>& points) {
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

// The first point (in the job's order) whose name an earlier point has, or -1 — what inserting
// every name into a set in order finds, without a set of 10^6 strings (a scan's plan: 0.24 s of
// allocations and comparisons). The names' hashes with their indices go into 256 buckets by the
// hash's top byte, each bucket in index order (chunks of points counted, then placed, side by
// side); each bucket is sorted and searched on its own (FirstRepeatAmong): a repeated name has
// one hash, so its points share a bucket. The smallest index over the buckets is the answer,
// whatever the thread count.
std::ptrdiff_t FirstRepeatedName(const std::vector<JobPoint>& points, int threads) {
  constexpr std::size_t kChunk = 8192, kBuckets = 256;
  const std::size_t n = points.size(), chunks = (n + kChunk - 1) / kChunk;
  auto bucket_of = [](std::size_t hash) { return hash >> (8 * sizeof(std::size_t) - 8); };
  std::vector<KeyedName> keyed(n);
  std::vector<std::array<std::size_t, kBuckets>> at(chunks);  // per chunk: count, then next place
  parallel_internal::ForEachChunk(n, kChunk, threads, [&](std::size_t c, std::size_t b, std::size_t e) {
    at[c].fill(0);
    for (std::size_t i = b; i < e; ++i) {
      keyed[i] = {std::hash<std::string_view>{}(points[i].name), static_cast<std::uint32_t>(i)};
      ++at[c][bucket_of(keyed[i].first)];
    }
  });
  // Bucket k holds the points of chunk 0, then chunk 1, ...: in index order.
  std::array<std::size_t, kBuckets + 1> bucket_begin{};
  for (std::size_t k = 0, place = 0; k < kBuckets; ++k) {
    bucket_begin[k] = place;
    for (std::size_t c = 0; c < chunks; ++c) place += std::exchange(at[c][k], place);
    bucket_begin[k + 1] = place;
  }
  std::vector<KeyedName> bucketed(n);
  parallel_internal::ForEachChunk(n, kChunk, threads, [&](std::size_t c, std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) bucketed[at[c][bucket_of(keyed[i].first)]++] = keyed[i];
  });
  std::array<std::ptrdiff_t, kBuckets> first{};
  parallel_internal::ForEach(kBuckets, threads, [&](std::size_t k, int) {
    const auto begin = bucketed.begin() + static_cast<std::ptrdiff_t>(bucket_begin[k]);
    const auto end = bucketed.begin() + static_cast<std::ptrdiff_t>(bucket_begin[k + 1]);
    std::sort(begin, end);
    first[k] = FirstRepeatAmong(std::span<const KeyedName>(begin, end), points);
  });
  std::ptrdiff_t repeat = -1;
  for (const std::ptrdiff_t f : first) {
    if (f >= 0 && (repeat < 0 || f < repeat)) repeat = f;
  }
  return repeat;
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
  if (const std::ptrdiff_t repeat = FirstRepeatedName(job.points, threads); repeat >= 0) {
    const JobPoint& p = job.points[static_cast<std::size_t>(repeat)];
    throw InputError(p.where + ": point name '" + p.name + "' used twice");
  }
  ReadTasks(top, job, threads);
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
