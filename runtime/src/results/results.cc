// RunJob: a job through the GUM engine (vlt/gum.h), the Monte Carlo engine (vlt/mcm.h) and the
// validation of JCGM 101 8 (vlt/validation.h) into one Results struct.
#include "vlt/results.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <span>
#include <string>
#include <string_view>
#include <cstdio>
#include <sys/resource.h>
#include <unistd.h>
#include <limits>
#include <cmath>
#include <cstdlib>
#include <ctime>

#include "parallel/memory.h"
#include "parallel/pool.h"
#include "results/internal.h"
#include "vlt/error.h"
#include "vlt/fits.h"

namespace vlt {

const char* VltCommit() { return VLT_COMMIT; }
const char* VltBuildType() { return VLT_BUILD_TYPE; }

std::string RunCreatedTime() {
  std::time_t now = std::time(nullptr);
  if (const char* epoch = std::getenv("SOURCE_DATE_EPOCH")) {
    char* end = nullptr;
    const long long v = std::strtoll(epoch, &end, 10);
    if (end != epoch && *end == '\0' && v >= 0) now = static_cast<std::time_t>(v);
  }
  std::tm utc{};
  gmtime_r(&now, &utc);
  char buffer[32];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return buffer;
}

McmSettings results_internal::McmSettingsFor(const MonteCarloSettings& job, const RunOptions& options, int threads,
                                             const std::string& file) {
  McmSettings settings;
  settings.seed = options.seed.value_or(job.seed);
  settings.trials = options.trials.value_or(job.adaptive ? 0 : job.trials);
  settings.coverage_probability = job.coverage_probability;
  settings.significant_digits = job.n_dig;
  settings.num_threads = threads;
  settings.device = options.device.value_or(job.device);
  settings.device_where = options.device ? "command line: --device" : file + ": monte_carlo.device";
  settings.quiet = !options.progress;
  return settings;
}

std::vector<PointReadings> JobReadings(const Job& job, const MeasurementModel& model, int threads) {
  std::vector<PointReadings> readings;
  parallel_internal::ReserveMapped(readings, job.points.size(), threads);
  readings.resize(job.points.size());
  // Chunks of points side by side (a scan's 10^6 inverse solutions); a failure names the first
  // failing point in job order, whatever the thread count (parallel/pool.h).
  constexpr std::size_t kChunk = 512;
  parallel_internal::ForEachChunk(
      job.points.size(), kChunk, threads, [&](std::size_t, std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) {
          const JobPoint& p = job.points[i];
          PointReadings& r = readings[i];
          r.name = p.name;
          if (job.mode == JobMode::kPlan) {
            // Offline: the readings that measure the nominal point with every input at its estimate.
            try {
              r.readings = ReadingsForPartPoint(model, p.nominal, p.face == Face::kBack, p.name);
            } catch (const NumericalError& e) {
              throw NumericalError(p.where + ": " + e.what());
            }
          } else {
            r.readings = p.readings;
          }
        }
      });
  return readings;
}

MapResult ComputeMap(const MeasurementModel& model, const MapSettings& settings, double coverage_probability,
                     int threads) {
  MapResult map;
  map.settings = settings;
  map.coverage_probability = coverage_probability;
  map.k = NormalCoverageFactor(coverage_probability);
  map.nodes = settings.Nodes();
  const std::size_t n = map.nodes.size();
  map.computed.assign(n, 0);
  map.U.assign(n, Eigen::Vector3d::Zero());
  map.U_norm.assign(n, 0.0);
  std::vector<Eigen::Vector3d> readings;
  std::vector<std::size_t> index;
  readings.reserve(n);
  index.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& node = map.nodes[i];
    Eigen::Vector3d t = PartToTrackerNominal(model.setup(), node);
    std::string reason;
    if (t.norm() < kMapAxisClearance) {
      reason = "at the tracker's gimbal point";
    } else if (std::hypot(t.x(), t.y()) < kMapAxisClearance) {
      reason = "on the tracker's vertical axis (azimuth undefined)";
    } else if (!(t.norm() <= kMaxRange)) {
      reason = "beyond any laser tracker (more than 10 km from the tracker, kMaxRange)";
    } else {
      try {
        readings.push_back(ReadingsForPartPoint(model, node, false, "map node"));
        index.push_back(i);
        continue;
      } catch (const NumericalError& e) {
        reason = e.what();
      }
    }
    map.skipped.push_back(base_internal::FormatNode(node) + ": " + reason);
  }
  std::vector<Eigen::Vector3d> field =
      ExpandedUncertaintyField(model, readings, coverage_probability, threads);
  for (std::size_t j = 0; j < index.size(); ++j) {
    std::size_t i = index[j];
    map.computed[i] = 1;
    map.U[i] = field[j];
    map.U_norm[i] = field[j].norm();
    if (!std::isfinite(map.U_norm[i])) {
      throw NumericalError("map node " + base_internal::FormatNode(map.nodes[i]) + ": non-finite uncertainty");
    }
  }
  // Per source and per group: the columns of [J_r U_r^1/2 | J_s F] (vlt/gum.h), in quadrature.
  const std::vector<UncertaintySource> sources = UncertaintySources(model);
  const Eigen::MatrixXd by_source =
      ExpandedUncertaintyBySource(model, readings, coverage_probability, threads);
  std::vector<double> group_sq;
  for (const UncertaintySource& s : sources) {
    map.sources.push_back({s.name, s.group, std::vector<double>(n, 0.0)});
    if (std::none_of(map.groups.begin(), map.groups.end(),
                     [&](const MapResult::Layer& g) { return g.name == s.group; })) {
      map.groups.push_back({s.group, s.group, std::vector<double>(n, 0.0)});
    }
  }
  map.dominant.assign(n, -1);
  for (std::size_t j = 0; j < index.size(); ++j) {
    const std::size_t i = index[j];
    const Eigen::Index col = static_cast<Eigen::Index>(j);
    double largest = -1.0;
    for (std::size_t s = 0; s < sources.size(); ++s) {
      const double u = by_source(static_cast<Eigen::Index>(s), col);
      map.sources[s].U[i] = u;
      // Ties within rounding (1e-9 relative: equal azimuth and elevation noise at elevation 0, say)
      // go to the first source, so that equal contributions do not make a checkerboard.
      if (u > largest * (1.0 + 1e-9)) {
        largest = u;
        map.dominant[i] = static_cast<int>(s);
      }
      for (MapResult::Layer& g : map.groups) {
        if (g.name == sources[s].group) g.U[i] += u * u;
      }
    }
    for (MapResult::Layer& g : map.groups) g.U[i] = std::sqrt(g.U[i]);
  }
  return map;
}

void MarkJobOnMap(const Job& job, const MeasurementModel& model, MapResult& map) {
  const Eigen::VectorXd x = model.shared_estimates();
  map.markers.push_back({"tracker", model.ThermalScale(x.data()) * model.PoseTranslation(x.data()), false});
  if (job.points.size() > kMaxMapPointMarkers) return;
  for (const JobPoint& p : job.points) {
    Eigen::Vector3d where = p.nominal;
    if (job.mode == JobMode::kReadings) model.Evaluate(p.readings.data(), x.data(), where.data());
    map.markers.push_back({p.name, where, true});
  }
}

void AddMonteCarloToMap(const Job& job, const RunOptions& options, MapResult& map) {
  Job nodes = job;
  nodes.mode = JobMode::kPlan;
  nodes.points.clear();
  nodes.tasks.clear();
  nodes.task_points.clear();
  nodes.map.reset();
  nodes.monte_carlo.enabled = true;
  std::vector<std::size_t> index;
  for (std::size_t i = 0; i < map.nodes.size(); ++i) {
    if (!map.computed[i]) continue;
    JobPoint p;
    p.name = "node " + std::to_string(i);
    p.nominal = map.nodes[i];
    p.where = job.file + ": map: node " + base_internal::FormatNode(map.nodes[i]);
    nodes.points.push_back(std::move(p));
    index.push_back(i);
  }
  map.has_mcm = true;
  map.U_norm_mcm.assign(map.nodes.size(), 0.0);
  map.verdict.assign(map.nodes.size(), "");
  if (index.empty()) return;
  RunOptions run = options;
  run.monte_carlo = true;
  run.compute_map = false;
  const Results r = RunJob(nodes, run);
  map.mcm_trials = r.mcm.trials;
  map.mcm_seed = r.mcm.seed;
  for (std::size_t j = 0; j < index.size(); ++j) {
    const PointResult& p = r.points[j];
    map.U_norm_mcm[index[j]] = map.k * std::sqrt(p.monte_carlo->mcm.covariance.trace());
    map.verdict[index[j]] = p.outcome;
  }
}

namespace {

Results RunJobUnplaced(const Job& job, const RunOptions& options);

// A numerical failure found while computing names the point ("point 'P7': ..."); give it the
// place the point came from ("r.csv: line 9: point 'P7': ...", docs/cli.md: every error names
// its file and key or line).
std::string Placed(const Job& job, const std::string& message) {
  if (message.rfind("point '", 0) != 0) return job.file + ": " + message;
  const std::size_t end = message.find('\'', 7);
  if (end == std::string::npos) return job.file + ": " + message;
  const std::string name = message.substr(7, end - 7);
  for (const JobPoint& p : job.points) {
    if (p.name == name) return p.where + ": " + message;
  }
  return job.file + ": " + message;
}

}  // namespace

namespace {

// ISO 14253-1 / JCGM 106 for the task quantities with a tolerance (TaskResult::conformity).
void DecideTaskConformity(TaskResult& task) {
  task.conformity.assign(task.gum.quantities.size(), std::nullopt);
  for (const auto& [quantity, tol] : task.spec.tolerances) {
    for (std::size_t q = 0; q < task.gum.quantities.size(); ++q) {
      if (task.gum.quantities[q] != quantity) continue;
      const Eigen::Index i = static_cast<Eigen::Index>(q);
      const bool differentiable = q >= task.gum.differentiable.size() || task.gum.differentiable[q];
      const bool mcm = task.has_mcm && q < task.mcm.size();
      std::optional<double> p_mcm = mcm ? task.mcm[q].conformity_probability : std::nullopt;
      if (!results_internal::DecidedByMonteCarlo(task, q) && differentiable) {
        task.conformity[q] = DecideConformity(tol, task.gum.value[i], task.gum.u[i], task.gum.U[i], p_mcm);
        continue;
      }
      // No GUM value (vlt/fits.h: a form quantity of points that fit exactly; a first-order u of 0
      // to rounding) or one Monte Carlo does not validate: the decision rule with the Monte Carlo
      // shortest coverage interval in place of y +- U.
      ConformityDecision d;
      if (!mcm) {
        d.verdict = "undetermined";
        task.conformity[q] = d;
        continue;
      }
      const CoverageInterval& ci = task.mcm[q].shortest;
      d.guard_band = 0.5 * (ci.high - ci.low);
      d.acceptance_lower = tol.lower;
      d.acceptance_upper = tol.upper;
      d.verdict = (ci.low >= tol.lower && ci.high <= tol.upper) ? "conforms"
                  : (ci.high < tol.lower || ci.low > tol.upper) ? "does not conform"
                                                                : "undetermined";
      d.probability_mcm = p_mcm;
      task.conformity[q] = d;
    }
  }
}

}  // namespace

std::uint64_t EstimateJobMemory(const Job& job, const RunOptions& options) {
  const std::uint64_t shared = static_cast<std::uint64_t>(job.setup.model ? job.setup.model->num_params : 0) +
                               (job.setup.environment ? 4 : 0) + (job.setup.pose ? 6 : 0) +
                               (job.setup.thermal ? 2 : 0);
  const auto n = static_cast<std::uint64_t>(job.points.size());
  std::uint64_t bytes = kJobBaseBytes + n * (kBytesPerPoint + (3 + shared) * kBytesPerPointInput);
  if (options.monte_carlo && job.monte_carlo.enabled) {
    const std::int64_t trials =
        options.trials.value_or(job.monte_carlo.adaptive ? 0 : job.monte_carlo.trials);
    std::uint64_t outputs = 3 * n;
    for (const TaskSpec& t : job.tasks) outputs += TaskOutputs(t.kind).size();
    const McmSettings defaults;
    const std::uint64_t batch =
        trials > 0 ? std::min<std::uint64_t>(10000, static_cast<std::uint64_t>(trials)) : 10000;
    const std::uint64_t stored =
        trials > 0 ? std::min<std::uint64_t>(defaults.memory_budget_bytes,
                                             4 * outputs * static_cast<std::uint64_t>(trials))
                   : defaults.memory_budget_bytes;
    bytes += n * kBytesPerPointMcm + 4 * outputs * batch + stored;
  }
  return bytes;
}

namespace {

// The machine's: MemAvailable of /proc/meminfo (Linux, kB); else the physical memory.
std::uint64_t MachineMemoryAvailable() {
  if (std::FILE* f = std::fopen("/proc/meminfo", "r")) {
    char line[256];
    unsigned long long kb = 0;
    bool found = false;
    while (std::fgets(line, sizeof line, f)) {
      if (std::sscanf(line, "MemAvailable: %llu kB", &kb) == 1) {
        found = true;
        break;
      }
    }
    std::fclose(f);
    if (found) return static_cast<std::uint64_t>(kb) * 1024;
  }
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page)
                               : std::numeric_limits<std::uint64_t>::max();
}

// What is left of the process's address-space limit (`ulimit -v`, RLIMIT_AS) beyond the address
// space it maps already (/proc/self/statm); no limit: the largest value.
std::uint64_t AddressSpaceLeft() {
  rlimit limit{};
  if (getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) {
    return std::numeric_limits<std::uint64_t>::max();
  }
  unsigned long long pages = 0;
  if (std::FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%llu", &pages) != 1) pages = 0;
    std::fclose(f);
  }
  const std::uint64_t mapped = pages * static_cast<std::uint64_t>(std::max(sysconf(_SC_PAGE_SIZE), 1L));
  return limit.rlim_cur > mapped ? limit.rlim_cur - mapped : 0;
}

// What is left of the memory limits of the process's control group and its ancestors (cgroup v2:
// a container's, a systemd unit's or slice's memory.max), each less what the group uses beyond its
// reclaimable page cache (memory.current less memory.stat's inactive_file, as the kernel would
// reclaim that first: a runner that has read a lot of files sits near its limit in cache alone);
// no limit: the largest value.
std::uint64_t ControlGroupMemoryLeft() {
  std::string group;
  if (std::FILE* f = std::fopen("/proc/self/cgroup", "r")) {
    char line[4096];
    while (std::fgets(line, sizeof line, f)) {
      if (std::string_view(line).starts_with("0::")) {
        group = std::string(line + 3);
        while (!group.empty() && (group.back() == '\n' || group.back() == '\r')) group.pop_back();
      }
    }
    std::fclose(f);
  }
  // The number after `key` in a file of the group ("" : the file's first number); "max" reads as
  // no number: no limit.
  auto read_number = [](const std::string& dir, const char* file, const char* key, unsigned long long* value) {
    std::FILE* f = std::fopen((dir + "/" + file).c_str(), "r");
    if (f == nullptr) return false;
    bool read = false;
    if (*key == '\0') {
      read = std::fscanf(f, "%llu", value) == 1;
    } else {
      char name[256];
      unsigned long long number = 0;
      while (!read && std::fscanf(f, "%255s %llu", name, &number) == 2) {
        if (std::string_view(name) == key) {
          *value = number;
          read = true;
        }
      }
    }
    std::fclose(f);
    return read;
  };
  std::uint64_t left = std::numeric_limits<std::uint64_t>::max();
  while (!group.empty() && group.front() == '/') {
    const std::string dir = "/sys/fs/cgroup" + (group == "/" ? std::string() : group);
    unsigned long long max = 0, current = 0, cache = 0;
    if (read_number(dir, "memory.max", "", &max) && read_number(dir, "memory.current", "", &current)) {
      if (!read_number(dir, "memory.stat", "inactive_file", &cache)) cache = 0;
      const unsigned long long used = current > cache ? current - cache : 0;
      left = std::min<std::uint64_t>(left, max > used ? max - used : 0);
    }
    if (group == "/") break;
    const std::size_t slash = group.find_last_of('/');
    group = slash == 0 ? "/" : group.substr(0, slash);
  }
  return left;
}

}  // namespace

std::uint64_t AvailableMemory() {
  // The least of the machine's available memory, the address-space limit's remainder and the
  // control group's: a job refused by the first would otherwise end in std::bad_alloc under the
  // others (`ulimit -v`, a container), an internal error where the user gave too large a job.
  return std::min({MachineMemoryAvailable(), AddressSpaceLeft(), ControlGroupMemoryLeft()});
}

void CheckJobMemory(const Job& job, std::uint64_t available_bytes, const RunOptions& options) {
  const std::uint64_t need = EstimateJobMemory(job, options);
  if (need <= available_bytes) return;
  const double gib = 1024.0 * 1024.0 * 1024.0;
  const std::uint64_t per_point = job.points.empty() ? 1 : (need - kJobBaseBytes) / job.points.size();
  const std::uint64_t fits =
      available_bytes > kJobBaseBytes ? (available_bytes - kJobBaseBytes) / per_point : 0;
  char text[512];
  std::snprintf(
      text, sizeof text,
      ": this job needs about %.1f GiB of memory (%zu points x %.1f kB%s) and %.1f GiB are available; "
      "split it into jobs of at most %llu points",
      static_cast<double>(need) / gib, job.points.size(), static_cast<double>(per_point) / 1024.0,
      options.monte_carlo && job.monte_carlo.enabled ? ", with the Monte Carlo values of every output" : "",
      static_cast<double>(available_bytes) / gib, static_cast<unsigned long long>(fits));
  throw InputError(job.file + (job.mode == JobMode::kPlan ? ": plan" : ": readings") + text);
}

namespace {

// The full GUM results of points [begin, end) of `indices` (all points when empty), computed on
// one thread: PropagatePoints of the readings the run propagated, with the run's second-order
// check and the names that PointResult keeps once.
std::vector<PointUncertainty> DetailsOf(const Results& r, const MeasurementModel& model,
                                        std::span<const std::size_t> indices, std::size_t begin,
                                        std::size_t end, bool budgets) {
  auto at = [&](std::size_t i) -> const PointResult& { return r.points[indices.empty() ? i : indices[i]]; };
  std::vector<PointReadings> chunk(end - begin);
  for (std::size_t i = begin; i < end; ++i) {
    chunk[i - begin].name = at(i).input.name;
    chunk[i - begin].readings = at(i).gum.readings;
  }
  GumOptions options;
  options.coverage_probability = r.coverage_probability;
  options.budgets = budgets;
  options.threads = 1;  // the caller runs chunks in parallel
  std::vector<PointUncertainty> details = PropagatePoints(model, chunk, options);
  for (std::size_t i = begin; i < end; ++i) {
    const PointGum& kept = at(i).gum;
    PointUncertainty& d = details[i - begin];
    d.second_order_variance = kept.second_order_variance;
    d.second_order_ratio = kept.second_order_ratio;
    d.gum_reliable = kept.gum_reliable;
    d.second_order_decided = kept.second_order_decided;
  }
  return details;
}

}  // namespace

void results_internal::WriteInBlocks(OutputText& out, std::size_t n, int threads,
                             const std::function<void(std::size_t, std::size_t, std::string&)>& format) {
  // Blocks of at most kBlock items, all of one size (to one item), each cut into kParts parts
  // formatted in parallel, each into its own text, then written in order; the text does not
  // depend on the thread count. 128 parts: 8 for each of 16 threads in every block, the last one
  // too (issue 33); a block of the full budget.csv text is then about 60 MB (8192 points of 7 kB).
  // The previous block is written while this one is formatted: one more item (129), the first
  // handed out, so that no thread waits for the disk (a 10^6-point scan's points.csv: 0.3 s of
  // writes). Two blocks of text are held then (the full budget.csv: about 120 MB).
  constexpr std::size_t kBlock = 8192, kParts = 128;
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  std::array<std::vector<std::string>, 2> parts{std::vector<std::string>(kParts),
                                                std::vector<std::string>(kParts)};
  std::size_t written_count = 0;  // parts of the previous block, in parts[(b - 1) % 2]
  auto write_previous = [&](std::size_t b) {
    for (std::size_t c = 0; c < written_count; ++c) out.Write(parts[(b + 1) % 2][c]);
  };
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t begin = n * b / blocks, len = n * (b + 1) / blocks - begin;
    const std::size_t count = std::min(kParts, len);
    std::vector<std::string>& formatted = parts[b % 2];
    parallel_internal::ForEach(count + 1, threads, [&](std::size_t item, int) {
      if (item == 0) return write_previous(b);
      const std::size_t c = item - 1;
      formatted[c].clear();
      format(begin + len * c / count, begin + len * (c + 1) / count, formatted[c]);
    });
    written_count = count;
  }
  write_previous(blocks);
}

void results_internal::WritePointDetails(
    const Results& r, OutputText& out, bool budgets,
    const std::function<void(std::size_t, std::span<const PointUncertainty>, std::string&)>& format) {
  if (r.points.empty()) return;
  const MeasurementModel model(r.setup);
  WriteInBlocks(out, r.points.size(), r.threads, [&](std::size_t begin, std::size_t end, std::string& text) {
    format(begin, DetailsOf(r, model, {}, begin, end, budgets), text);
  });
}

PointGum KeptOf(const PointUncertainty& point) {
  PointGum kept;
  kept.readings = point.readings;
  kept.part = point.part;
  kept.cov_part = point.cov_part;
  kept.k = point.k;
  kept.second_order_variance = point.second_order_variance;
  kept.second_order_ratio = point.second_order_ratio;
  kept.gum_reliable = point.gum_reliable;
  kept.second_order_decided = point.second_order_decided;
  return kept;
}

std::vector<PointUncertainty> PointDetails(const Results& results, std::span<const std::size_t> indices,
                                           bool budgets, int threads) {
  const std::size_t n = indices.empty() ? results.points.size() : indices.size();
  std::vector<PointUncertainty> details(n);
  if (n == 0) return details;
  for (const std::size_t i : indices) {
    if (i >= results.points.size()) throw std::out_of_range("PointDetails: no point " + std::to_string(i));
  }
  const MeasurementModel model(results.setup);
  // Chunks of a fixed size (not of the thread count): the same work, the same bits, any count.
  constexpr std::size_t kChunk = 256;
  parallel_internal::ForEachChunk(n, kChunk, threads, [&](std::size_t, std::size_t b, std::size_t e) {
    std::vector<PointUncertainty> part = DetailsOf(results, model, indices, b, e, budgets);
    std::move(part.begin(), part.end(), details.begin() + static_cast<std::ptrdiff_t>(b));
  });
  return details;
}

Results RunJob(const Job& job, const RunOptions& options) {
  // A job too large for memory fails here, before computing, not with std::bad_alloc.
  CheckJobMemory(job, AvailableMemory(), options);
  try {
    return RunJobUnplaced(job, options);
  } catch (const NumericalError& e) {
    const std::string message = e.what();
    if (message.rfind(job.file, 0) == 0) throw;  // already placed
    throw NumericalError(Placed(job, message));
  }
}

namespace {

// What the run is: the program, the job and the settings its results are given for.
Results RunHeader(const Job& job) {
  Results results;
  results.vlt_version = VLT_VERSION;
  results.vlt_commit = VltCommit();
  results.created = RunCreatedTime();
  results.input_files = job.input_files;
  results.job_file = job.file;
  results.job_name = job.name;
  results.job_description = job.description;
  results.record = job.record;
  results.calibration = job.calibration;
  results.mode = job.mode;
  results.model_name = job.setup.model ? job.setup.model->name : "";
  results.setup = job.setup;
  results.coverage_probability = job.monte_carlo.coverage_probability;
  results.n_dig = job.monte_carlo.n_dig;
  results.ellipsoid_scale = job.output.ellipsoid_scale;
  results.detail = ResolvedDetail(job.output.detail, job.points.size());
  results.arrays = job.output.arrays;
  return results;
}

// What the results keep of a job's point: all but where it was defined (a text for the job's
// messages, 40 bytes a point of a scan on the heap).
JobPoint JobPointKept(const JobPoint& point) {
  JobPoint kept = point;
  std::string().swap(kept.where);
  return kept;
}

// The GUM uncertainty of every point of the job.
void PropagateJobPoints(const Job& job, const MeasurementModel& model,
                        const std::vector<PointReadings>& readings, const GumOptions& gum_options,
                        Results& results) {
  // In blocks kept (PointGum) as they are done: a scan never holds the full result of more than
  // one block (point names are never empty, so messages name the point, not a block position).
  parallel_internal::ReserveMapped(results.points, job.points.size(), gum_options.threads);
  results.points.resize(job.points.size());
  constexpr std::size_t kGumBlock = 65536;
  std::vector<PointUncertainty> gum_points;  // one block's full results, its records reused
  for (std::size_t begin = 0; begin < readings.size(); begin += kGumBlock) {
    const std::span<const PointReadings> block(readings.data() + begin,
                                               std::min(kGumBlock, readings.size() - begin));
    PropagatePoints(model, block, gum_options, gum_points);
    // Where the linearisation is not reliable, said without Monte Carlo (JCGM 100 5.1.2 note).
    CheckSecondOrder(model, block, gum_points, kSecondOrderThreshold, gum_options.threads);
    if (begin == 0 && !gum_points.empty()) results.correlation_handling = gum_points[0].correlation_handling;
    // 128 chunks whatever the block's size (the last block of a scan is short).
    const std::size_t chunk = std::max<std::size_t>(1, (block.size() + 127) / 128);
    parallel_internal::ForEachChunk(block.size(), chunk, gum_options.threads,
                                    [&](std::size_t, std::size_t b, std::size_t e) {
                                      for (std::size_t i = b; i < e; ++i) {
                                        PointResult& point = results.points[begin + i];
                                        point.input = JobPointKept(job.points[begin + i]);
                                        point.gum = KeptOf(gum_points[i]);
                                      }
                                    });
  }
}

// "<file>: <table>" of task t for a message: the table that defined it.
std::string TaskWhere(const Job& job, std::size_t t) {
  const std::string& where = job.tasks[t].where;
  return where.empty() ? job.file + ": task[" + std::to_string(t) + "]" : where;
}

// The GUM uncertainty of every task of the job.
void PropagateJobTasks(const Job& job, const MeasurementModel& model,
                       const std::vector<PointReadings>& readings, const GumOptions& gum_options,
                       Results& results) {
  results.tasks.resize(job.tasks.size());
  for (std::size_t t = 0; t < job.tasks.size(); ++t) {
    results.tasks[t].spec = job.tasks[t];
    results.tasks[t].point_indices = job.task_points[t];
    try {
      results.tasks[t].gum = PropagateTask(model, readings, job.tasks[t], job.task_points[t], gum_options);
    } catch (const NumericalError& e) {
      throw NumericalError(TaskWhere(job, t) + ": " + e.what());
    } catch (const InputError& e) {
      throw InputError(TaskWhere(job, t) + ": " + e.what());
    }
  }
}

// Task outputs follow the points (3 each), task by task, in MakeMcmTask's order: the index
// of each task's first Monte Carlo output.
std::vector<std::size_t> TaskFirstOutputs(const McmJob& mcm_job, std::size_t points) {
  std::vector<std::size_t> task_first_output(mcm_job.tasks.size());
  std::size_t offset = 3 * points;
  for (std::size_t t = 0; t < mcm_job.tasks.size(); ++t) {
    task_first_output[t] = offset;
    offset += mcm_job.tasks[t].output_names.size();
  }
  return task_first_output;
}

// Task tolerances: count the trials inside them (JCGM 106 7.2.1).
void AddTaskTolerances(const Results& results, const McmJob& mcm_job,
                       const std::vector<std::size_t>& task_first_output, McmSettings& settings) {
  for (std::size_t t = 0; t < results.tasks.size(); ++t) {
    const McmTask& mt = mcm_job.tasks[t];
    for (const auto& [quantity, tol] : results.tasks[t].spec.tolerances) {
      const std::string wanted = results.tasks[t].spec.name + "." + quantity;
      for (std::size_t j = 0; j < mt.output_names.size(); ++j) {
        if (mt.output_names[j] == wanted) {
          settings.tolerances.push_back({static_cast<int>(task_first_output[t] + j), tol.lower, tol.upper});
        }
      }
    }
  }
}

// The GUM results of point i validated by Monte Carlo (JCGM 101 8): per axis, and its region.
void ValidatePointResult(const McmResult& mcm, std::size_t i, Results& results) {
  PointResult& pr = results.points[i];
  pr.has_mcm = true;
  auto m = std::make_shared<PointMcm>();
  m->mcm = mcm.points[i];
  std::vector<std::string> outcomes;
  // What rounding leaves in a coordinate: 64 ulps of the largest of the point's part-frame
  // coordinates and its range (its tracker-frame size), as for a task's outputs
  // (ValidateTaskResult), so that a coordinate whose GUM u and Monte Carlo spread are both
  // rounding (every input's u 0) is judged exact, not on its noise.
  const double size = std::max(pr.gum.part.cwiseAbs().maxCoeff(), std::abs(pr.gum.readings(0)));
  const double resolution = 64.0 * std::numeric_limits<double>::epsilon() * size;
  bool exact = true;
  for (int a = 0; a < 3; ++a) {
    m->axes[a] = mcm.outputs[3 * i + a];
    m->axis_validation[a] = ValidateScalar(m->axes[a].name, "m", pr.gum.part[a], pr.gum.u_part()[a],
                                           pr.gum.U_part()[a], m->axes[a].symmetric, results.n_dig, mcm.trials,
                                           m->axes[a].u, results.coverage_probability, true, resolution);
    CheckFiniteVariance(m->axes[a], m->axis_validation[a]);
    outcomes.push_back(m->axis_validation[a].outcome);
    exact = exact && m->axis_validation[a].exact && m->axis_validation[a].outcome == "validated";
  }
  if (exact) {
    // No spread on any axis, in the GUM or the Monte Carlo: both regions are the point itself,
    // and there is no ellipsoid to compare (its covariance is 0).
    m->region_validation = PointValidation{};
    m->region_validation.name = pr.input.name;
    m->region_validation.gum_coverage_factor = results.k_region;
    m->region_validation.outcome = "not applicable";
    m->region_validation.verdict =
        "not applicable: every coordinate is exact (its GUM u and Monte Carlo interval below the numerical "
        "resolution), so both coverage regions are the point";
    pr.monte_carlo = std::move(m);
    pr.outcome = CombinedOutcome(outcomes);
    pr.validated = pr.outcome == "validated";
    results.validated_points += pr.validated ? 1 : 0;
    return;
  }
  try {
    m->region_validation = ValidatePoint(pr.input.name, pr.gum.part, pr.gum.cov_part, results.k_region,
                                         m->mcm, results.n_dig, mcm.trials, results.coverage_probability);
    outcomes.push_back(m->region_validation.outcome);
  } catch (const NumericalError& e) {
    m->region_validation = PointValidation{};
    m->region_validation.name = pr.input.name;
    m->region_validation.outcome = "not validated";
    m->region_validation.verdict = std::string("no coverage region: ") + e.what();
    outcomes.push_back("not validated");
  }
  pr.monte_carlo = std::move(m);
  pr.outcome = CombinedOutcome(outcomes);
  pr.validated = pr.outcome == "validated";
  results.validated_points += pr.validated ? 1 : 0;
  results.inconclusive_points += pr.outcome == "inconclusive" ? 1 : 0;
}

// Task outputs (task_first_output) are matched to the GUM quantities by name.
void ValidateTaskResult(const McmResult& mcm, const McmTask& mt, std::size_t offset, TaskResult& task,
                        Results& results) {
  if (offset + mt.output_names.size() > mcm.outputs.size()) {
    throw std::logic_error("Monte Carlo result has too few task outputs");
  }
  task.has_mcm = true;
  double coordinate_size = 0.0;  // the largest coordinate of the task's points [m]
  for (const int i : task.point_indices) {
    if (i >= 0 && static_cast<std::size_t>(i) < results.points.size()) {
      coordinate_size = std::max(coordinate_size, results.points[static_cast<std::size_t>(i)].gum.part.cwiseAbs().maxCoeff());
    }
  }
  std::vector<std::string> outcomes;
  for (std::size_t q = 0; q < task.gum.quantities.size(); ++q) {
    const std::string wanted = task.spec.name + "." + task.gum.quantities[q];
    std::size_t j = 0;
    while (j < mt.output_names.size() && mt.output_names[j] != wanted) ++j;
    if (j == mt.output_names.size()) {
      throw std::logic_error("Monte Carlo task output '" + wanted + "' missing");
    }
    task.mcm.push_back(mcm.outputs[offset + j]);
    const bool differentiable = q >= task.gum.differentiable.size() || task.gum.differentiable[q];
    // Lengths are computed from the points' coordinates: 64 ulps of the largest of them (and of
    // the value) is what rounding leaves; other units from values of order one.
    const double size = std::max(std::abs(task.gum.value[q]), task.gum.units[q] == "m" ? coordinate_size : 1.0);
    const double resolution = 64.0 * std::numeric_limits<double>::epsilon() * size;
    task.validation.push_back(ValidateScalar(
        wanted, task.gum.units[q], task.gum.value[q], task.gum.u[q], task.gum.U[q], task.mcm.back().symmetric,
        results.n_dig, mcm.trials, task.mcm.back().u, results.coverage_probability, differentiable, resolution));
    CheckFiniteVariance(task.mcm.back(), task.validation.back());
    outcomes.push_back(task.validation.back().outcome);
  }
  task.outcome = CombinedOutcome(outcomes);
  task.validated = task.outcome == "validated";
  results.validated_tasks += task.validated ? 1 : 0;
}

// Monte Carlo (JCGM 101 / 102) on the same model, and the validation of JCGM 101 8.
void RunMonteCarlo(const Job& job, const RunOptions& options, const MeasurementModel& model,
                   const std::vector<PointReadings>& readings, int threads, Results& results) {
  McmJob mcm_job;
  mcm_job.model = &model;
  for (const PointReadings& r : readings) mcm_job.points.push_back(McmPoint{r.name, r.readings});
  for (const TaskResult& task : results.tasks) {
    mcm_job.tasks.push_back(results_internal::MakeMcmTask(task.spec, task.point_indices, task.gum));
  }
  const std::vector<std::size_t> task_first_output = TaskFirstOutputs(mcm_job, readings.size());
  McmSettings settings = results_internal::McmSettingsFor(job.monte_carlo, options, threads, job.file);
  AddTaskTolerances(results, mcm_job, task_first_output, settings);
  auto mcm_start = std::chrono::steady_clock::now();
  McmResult mcm = RunMcm(mcm_job, settings);
  results.mcm_seconds = base_internal::Seconds(mcm_start);
  results.has_mcm = true;

  const std::size_t np = results.points.size();
  if (mcm.points.size() != np || mcm.outputs.size() < 3 * np) {
    throw std::logic_error("Monte Carlo result does not match the job's points");
  }
  for (std::size_t i = 0; i < np; ++i) ValidatePointResult(mcm, i, results);
  for (std::size_t t = 0; t < results.tasks.size(); ++t) {
    ValidateTaskResult(mcm, mcm_job.tasks[t], task_first_output[t], results.tasks[t], results);
  }
  mcm.outputs.clear();
  mcm.points.clear();
  results.mcm = std::move(mcm);
}

Results RunJobUnplaced(const Job& job, const RunOptions& options) {
  Results results = RunHeader(job);
  const int threads = options.threads.value_or(job.monte_carlo.threads);

  MeasurementModel model(job.setup);
  results.shared_inputs = model.shared_inputs();
  results.k_axis = NormalCoverageFactor(results.coverage_probability);
  results.k_region = ChiSquareCoverageFactor(results.coverage_probability, 3);

  // GUM (JCGM 100 5.1.2 / JCGM 102 6.2.1.3): every task, then every point.
  auto gum_start = std::chrono::steady_clock::now();
  std::vector<PointReadings> readings = JobReadings(job, model, threads);
  GumOptions gum_options;
  gum_options.coverage_probability = results.coverage_probability;
  // Budgets are recomputed (PointDetails) when the files are written (not held: O(N) memory).
  gum_options.budgets = false;
  gum_options.threads = threads;
  results.threads = threads;
  // Tasks first: a scan's task (its fit Jacobian, 8 x 3N doubles) is done and freed before the
  // points' results are held, so the two never add up (issue 33: a 10^6-point scan in 1 GiB).
  // Neither depends on the other. The error said stays a point's where a point is at fault: when
  // a task fails, the points are propagated and their error, if any, is thrown instead.
  try {
    PropagateJobTasks(job, model, readings, gum_options, results);
  } catch (const std::exception&) {
    PropagateJobPoints(job, model, readings, gum_options, results);
    throw;
  }
  PropagateJobPoints(job, model, readings, gum_options, results);
  results.gum_seconds = base_internal::Seconds(gum_start);

  if (options.monte_carlo && job.monte_carlo.enabled) {
    RunMonteCarlo(job, options, model, readings, threads, results);
  }

  for (TaskResult& task : results.tasks) DecideTaskConformity(task);

  if (job.map && options.compute_map) {
    results.map = ComputeMap(model, *job.map, results.coverage_probability, threads);
    MarkJobOnMap(job, model, *results.map);
    if (job.map->monte_carlo && options.monte_carlo && job.monte_carlo.enabled) {
      AddMonteCarloToMap(job, options, *results.map);
    }
  }
  return results;
}

}  // namespace

}  // namespace vlt
