// mcm/engine.cc — the Monte Carlo driver: batches (JCGM 101 7.9.4), chunks, threads, summary
// statistics (7.6), coverage intervals (7.7), JCGM 102 point covariance and coverage region.
//
// Determinism: trials are numbered 0, 1, 2, ...; every draw depends only on (seed, trial, input)
// (random.h). A batch is split into chunks of kChunk trials; each chunk sums its own deviations
// sequentially, and the chunk sums are added in chunk order, the batch sums in batch order. The
// values are stored at their trial's position. Nothing depends on which thread ran which chunk,
// so the result is bit-identical for any number of threads. Several batches are computed at once
// (a wave, sized for the threads: kItemsPerThread) and then accumulated one by one in batch order,
// so the wave's size does not change a bit either.
//
// MPI (docs/mpi.md): the chunks of a batch are shared out over the ranks in contiguous blocks
// (mpi_internal::Share); after each batch every rank receives every chunk's sums and every trial's values
// (mpi_internal::AllGather, exact copies), so every rank holds what one process would have held and goes
// on identically: the result is bit-identical for any number of ranks as well.
#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "mcm/engine.h"
#include "mcm/order.h"
#include "mcm/progress.h"
#include "mcm/sums.h"
#include "mcm/storage.h"
#include "model/correlation.h"
#include "mpi/ranks.h"
#include "parallel/pool.h"
#include "vlt/error.h"

namespace vlt::mcm_internal {

namespace {

// Per-batch values of the four statistics of 7.9.4 for one output.
struct BatchStats {
  std::vector<double> mean, u, low, high;           // per batch
  std::vector<double> shortest_low, shortest_high;  // only when values are not all kept
};

// Standard deviation of the average of h batch values: sqrt(sum (v - vbar)^2 / (h (h - 1))).
double StdOfAverage(const std::vector<double>& v) {
  const std::size_t h = v.size();
  if (h < 2) return 0.0;
  double mean = 0.0;
  for (double x : v) mean += x;
  mean /= static_cast<double>(h);
  double ss = 0.0;
  for (double x : v) ss += (x - mean) * (x - mean);
  return std::sqrt(ss / (static_cast<double>(h) * static_cast<double>(h - 1)));
}

double Average(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

// The component pointers of group g in a buffer holding `stride` values per output.
std::vector<const float*> GroupSeries(const float* base, std::int64_t stride, const OutputGroup& g) {
  std::vector<const float*> out;
  for (int a = 0; a < g.dim; ++a) out.push_back(base + (g.first + a) * stride);
  return out;
}

// The share of this rank in an MPI run (docs/mpi.md). Trials: the chunks of each batch, in
// contiguous blocks (mpi_internal::Share). Outputs: the order statistics of an output (the per-batch
// endpoints of 7.9.4, its coverage intervals, its histogram) and the coverage region of a group
// need every trial of that output, so after each batch the values are exchanged all-to-all and
// each rank keeps every trial of its own outputs: contiguous blocks of whole groups (a point's
// x, y, z stay together). Memory for the values and the order statistics are thus divided among
// the ranks as well as the trials. One rank: everything is its own.
struct OutputShare {
  int first = 0, last = 0;             // own outputs [first, last)
  std::vector<int> groups;             // own groups (their outputs are own outputs)
  std::vector<int> first_of, last_of;  // every rank's outputs

  OutputShare(int n_out, const std::vector<OutputGroup>& all_groups) {
    std::vector<int> group_at(static_cast<std::size_t>(n_out), -1);
    for (int g = 0; g < static_cast<int>(all_groups.size()); ++g) group_at[all_groups[g].first] = g;
    std::vector<int> block_start;  // a group's outputs form one block, any other output its own
    for (int o = 0; o < n_out;) {
      block_start.push_back(o);
      o += group_at[o] >= 0 ? all_groups[group_at[o]].dim : 1;
    }
    block_start.push_back(n_out);
    // Rank r's outputs start at the first block boundary at or after r n_out / R: shares of
    // nearly equal numbers of outputs (what the order statistics cost), never splitting a group.
    const int count = ranks::Count();
    auto boundary = [&](int r) {
      const std::int64_t target = (std::int64_t{r} * n_out + count / 2) / count;
      return *std::lower_bound(block_start.begin(), block_start.end(), static_cast<int>(target));
    };
    for (int r = 0; r < count; ++r) {
      first_of.push_back(boundary(r));
      last_of.push_back(boundary(r + 1));
    }
    first = first_of[ranks::Rank()];
    last = last_of[ranks::Rank()];
    for (int g = 0; g < static_cast<int>(all_groups.size()); ++g) {
      if (all_groups[g].first >= first && all_groups[g].first < last) groups.push_back(g);
    }
    // In output order: the ranks' records of their groups, one rank after the other, are then
    // every group in output order (RunEngine's final exchange).
    std::stable_sort(groups.begin(), groups.end(),
                     [&](int a, int b) { return all_groups[a].first < all_groups[b].first; });
  }
  int count() const { return last - first; }
};

// One batch in an MPI run: this rank computes the trials of its chunks for every output
// (`computed`, [o][trial - trial_first]); afterwards every rank holds the sums of every chunk
// (`partial`, chunk-major) and every trial of its own outputs (`values`, [o - first][trial]).
// Buffers are allocated before the batch is computed, so nothing can fail between the ranks'
// agreement (ranks::Agree) and the exchange. One rank: `computed` becomes `values`.
struct BatchExchange {
  int chunk_first = 0, chunk_last = 0;
  std::int64_t trial_first = 0, trial_count = 0;         // this rank's trials of the batch
  std::vector<std::int64_t> trials_first_of, trials_of;  // every rank's
  std::vector<std::size_t> sum_counts, send_counts, receive_counts;
  std::vector<double> sums_mine;
  std::vector<float> received;

  BatchExchange(int n_chunks, int stride, std::int64_t bh, int n_out, const OutputShare& share) {
    std::tie(chunk_first, chunk_last) = mpi_internal::Share(n_chunks);
    trial_first = std::min<std::int64_t>(bh, std::int64_t{chunk_first} * kChunk);
    trial_count = std::min<std::int64_t>(bh, std::int64_t{chunk_last} * kChunk) - trial_first;
    const int count = ranks::Count();
    if (count == 1) return;
    // MPI counts are int; checked here, before the ranks agree, by every rank alike.
    if (static_cast<std::size_t>(n_out) * static_cast<std::size_t>(bh) > static_cast<std::size_t>(INT_MAX)) {
      throw InputError("Monte Carlo under MPI: a batch of " + std::to_string(bh) + " trials of " +
                       std::to_string(n_out) +
                       " outputs exceeds one MPI message (2^31 - 1 values); "
                       "use fewer points per job");
    }
    for (int r = 0; r < count; ++r) {
      const auto [c0, c1] = mpi_internal::ShareOf(n_chunks, r);
      const std::int64_t t0 = std::min<std::int64_t>(bh, std::int64_t{c0} * kChunk);
      const std::int64_t t1 = std::min<std::int64_t>(bh, std::int64_t{c1} * kChunk);
      trials_first_of.push_back(t0);
      trials_of.push_back(t1 - t0);
      sum_counts.push_back(static_cast<std::size_t>(c1 - c0) * static_cast<std::size_t>(stride));
      send_counts.push_back(static_cast<std::size_t>(share.last_of[r] - share.first_of[r]) *
                            static_cast<std::size_t>(trial_count));
      receive_counts.push_back(static_cast<std::size_t>(share.count()) * static_cast<std::size_t>(t1 - t0));
    }
    sums_mine.resize(sum_counts[ranks::Rank()]);
    received.resize(static_cast<std::size_t>(share.count()) * static_cast<std::size_t>(bh));
  }

  void Exchange(std::vector<double>& partial, int stride, std::vector<float>& computed,
                std::vector<float>& values, std::int64_t bh, int n_own) {
    if (ranks::Count() == 1) {
      values.swap(computed);
      return;
    }
    std::copy_n(partial.begin() + static_cast<std::ptrdiff_t>(chunk_first) * stride, sums_mine.size(),
                sums_mine.begin());
    mpi_internal::AllGather(std::span<const double>(sums_mine), std::span<double>(partial), sum_counts);
    // `computed` is output-major, so the block for rank s (its outputs, this rank's trials) is
    // contiguous; the blocks received come rank after rank, each [own output][that rank's trials].
    mpi_internal::AllToAll(std::span<const float>(computed), send_counts, std::span<float>(received),
                           receive_counts);
    std::size_t at = 0;
    for (int r = 0; r < ranks::Count(); ++r) {
      for (int o = 0; o < n_own; ++o) {
        std::copy_n(received.begin() + static_cast<std::ptrdiff_t>(at), trials_of[r],
                    values.begin() + o * bh + trials_first_of[r]);
        at += static_cast<std::size_t>(trials_of[r]);
      }
    }
  }
};

// What each rank computed for its own outputs and groups, shared with every rank at the end:
// per output the numerical accuracy (7.9.4), both coverage intervals and the histogram; per group
// the coverage region (7.7.3 of JCGM 102). Plain doubles (counts are exact below 2^53).
constexpr int kOutputRecord = 14 + kHistogramBins;
constexpr int kGroupRecord = 2;

void PackOutput(const McmOutputResult& r, double* rec) {
  const McmOutputResult::Histogram& h = r.histogram;
  const double head[14] = {r.accuracy.s_mean,
                           r.accuracy.s_u,
                           r.accuracy.s_low,
                           r.accuracy.s_high,
                           r.symmetric.low,
                           r.symmetric.high,
                           r.shortest.low,
                           r.shortest.high,
                           h.low,
                           h.width,
                           static_cast<double>(h.below),
                           static_cast<double>(h.above),
                           r.tail_index ? *r.tail_index : -1.0,  // (an index is never negative)
                           r.infinite_variance ? 1.0 : 0.0};
  std::copy(head, head + 14, rec);
  for (int b = 0; b < kHistogramBins; ++b) {
    rec[14 + b] = h.counts.empty() ? -1.0 : static_cast<double>(h.counts[b]);
  }
}

void UnpackOutput(const double* rec, McmOutputResult& r) {
  r.accuracy.s_mean = rec[0];
  r.accuracy.s_u = rec[1];
  r.accuracy.s_low = rec[2];
  r.accuracy.s_high = rec[3];
  r.symmetric = {rec[4], rec[5]};
  r.shortest = {rec[6], rec[7]};
  McmOutputResult::Histogram& h = r.histogram;
  h.low = rec[8];
  h.width = rec[9];
  h.below = static_cast<std::int64_t>(rec[10]);
  h.above = static_cast<std::int64_t>(rec[11]);
  r.tail_index = rec[12] >= 0.0 ? std::optional<double>(rec[12]) : std::nullopt;
  r.infinite_variance = rec[13] != 0.0;
  h.counts.clear();
  if (rec[14] >= 0.0) {
    for (int b = 0; b < kHistogramBins; ++b) h.counts.push_back(static_cast<std::int64_t>(rec[14 + b]));
  }
}

std::string FormatStatus(double value, const char* what) {
  char text[96];
  std::snprintf(text, sizeof text, "%s %.3g", what, value);
  return text;
}

// The checks of the settings, before anything is computed.
void CheckSettings(const TrialKernel& kernel, const McmSettings& settings) {
  const double p = settings.coverage_probability;
  if (!(p > 0.0 && p < 1.0)) {
    throw InputError("Monte Carlo: coverage probability must be in (0, 1), got " + std::to_string(p));
  }
  if (settings.significant_digits != 1 && settings.significant_digits != 2) {
    throw InputError(
        "Monte Carlo: n_dig (significant digits of the numerical tolerance) must be "
        "1 or 2, got " +
        std::to_string(settings.significant_digits));
  }
  if (settings.trials < 0) {
    throw InputError("Monte Carlo: number of trials must be >= 0 (0 = adaptive), got " +
                     std::to_string(settings.trials));
  }
  for (const McmSettings::ToleranceCount& t : settings.tolerances) {
    if (t.output < 0 || t.output >= kernel.num_outputs() || !(t.lower <= t.upper)) {
      throw InputError("Monte Carlo: a tolerance needs an existing output and lower <= upper");
    }
  }
}

// 7.9.4 a): M = max(J, 10^4), J the smallest integer >= 100 / (1 - p).
std::int64_t BatchSize(const McmSettings& settings, bool adaptive) {
  const double p = settings.coverage_probability;
  const auto j_min = static_cast<std::int64_t>(std::ceil(100.0 / (1.0 - p) - 1e-9));
  std::int64_t batch_size = std::max<std::int64_t>(j_min, 10000);
  if (!adaptive) {
    CoverageCount(settings.trials, p);
    batch_size = std::min(batch_size, settings.trials);
  } else if (settings.max_trials < 2 * batch_size) {
    throw InputError("Monte Carlo: max_trials " + std::to_string(settings.max_trials) +
                     " is below two batches of " + std::to_string(batch_size) + " trials");
  }
  return batch_size;
}

// The outputs at the input estimates: the reference y0 of the stored deviations.
std::vector<double> OutputsAtEstimates(const TrialKernel& kernel, const OutputSpec& spec) {
  std::vector<double> y0 = kernel.AtEstimates();
  for (int o = 0; o < kernel.num_outputs(); ++o) {
    if (!std::isfinite(y0[o])) {
      throw NumericalError("Monte Carlo: output '" + spec.names[o] +
                           "' is not finite at the input estimates");
    }
  }
  return y0;
}

std::vector<Scratch> ThreadScratch(const TrialKernel& kernel, int threads) {
  std::vector<Scratch> scratch(threads);
  for (int w = 0; w < threads; ++w) kernel.InitScratch(scratch[w]);
  return scratch;
}

// Storage of every value of the own outputs: series[o - own_first][trial], float deviations
// from y0. The memory budget applies to the whole run (every output), so that the interval
// method does not depend on the number of ranks.
bool KeepsAllValues(const McmSettings& settings, bool adaptive, std::size_t bytes_per_trial) {
  return adaptive ||
         !(static_cast<std::size_t>(settings.trials) * bytes_per_trial > settings.memory_budget_bytes);
}

std::vector<ValueSeries> ValueStorage(int n_own, bool keep_all, bool direct, bool adaptive,
                                      std::int64_t trials) {
  std::vector<ValueSeries> series(keep_all ? n_own : 0);
  if (direct) {
    for (auto& s : series) s.resize(static_cast<std::size_t>(trials));
  } else if (keep_all && !adaptive) {
    for (auto& s : series) s.reserve(static_cast<std::size_t>(trials));
  }
  return series;
}

// Sums of a sub-batch: the points' three outputs together (AccumulatePoint), every other output
// and group on its own.
struct SumPlan {
  std::vector<int> fused_groups, other_groups, single_outputs;

  SumPlan(const OutputSpec& spec, int n_out) {
    const int n_groups = static_cast<int>(spec.groups.size());
    std::vector<bool> fused(static_cast<std::size_t>(n_out), false);
    for (int gi = 0; gi < n_groups; ++gi) {
      const OutputGroup& g = spec.groups[gi];
      if (g.dim == 3) {
        fused_groups.push_back(gi);
        for (int a = 0; a < 3; ++a) fused[g.first + a] = true;
      } else {
        other_groups.push_back(gi);
      }
    }
    for (int o = 0; o < n_out; ++o) {
      if (!fused[o]) single_outputs.push_back(o);
    }
  }
};

// One batch of trials [first, first + bh), split into n_chunks chunks.
struct Batch {
  std::int64_t first = 0, bh = 0;
  int n_chunks = 0;
  std::vector<double> partial;  // the sums of each chunk, chunk-major
  std::vector<float> vals;      // [o - own_first][trial] after the exchange
  std::vector<double> batch_sums;
  // 7.9.4 c), d) of a full batch, per own output: mean, u, y_low, y_high (kStatsPerOutput each),
  // computed with the other batches of its wave and added to `stats` when the batch is accumulated.
  std::vector<double> own_stats;
  double worst = 0.0;  // adaptive: this rank's worst 2 s / delta
  // A chunk that failed (a non-finite trial): its exception, raised when the batch is accumulated —
  // never for a batch of the wave beyond the one the run stops at, which one batch at a time would
  // not have computed. The lowest failing chunk's, as one batch at a time would report.
  std::exception_ptr failure;
  int failed_chunk = INT_MAX;
};

constexpr int kStatsPerOutput = 4;

// Batches computed together (a wave): one batch of 10^4 trials has only 4 chunks, so one batch at
// a time kept at most 4 threads busy. A wave holds enough batches for kItemsPerThread chunks (and
// per-batch statistics) per thread; its batches are then accumulated and checked (7.9.4 g) one
// after the other in trial order, exactly as one batch at a time: the run stops at the same batch
// and gives the same bits. An adaptive run computes at most a wave less one batch in vain.
constexpr int kItemsPerThread = 8;
// Batches that are not written in place (adaptive runs, MPI) hold their values until they are
// accumulated: a wave holds at most this many bytes of them (and at least one batch).
constexpr std::int64_t kWaveBytes = std::int64_t{256} << 20;

// The records of the final pass that every rank shares: its own, then everybody's.
struct FinalRecords {
  std::vector<double> own_outputs, own_groups;
  std::vector<std::size_t> output_counts, group_counts;
  std::vector<double> all_outputs, all_groups;
};

// A histogram pass's counts: the bins, below, above.
constexpr int kCells = kHistogramBins + 2;

// The state of one Monte Carlo run: the settings resolved, the values kept, the running sums and
// the per-batch statistics of 7.9.4, advanced batch by batch (RunBatches), then the final pass
// over the results (Result). Members are initialised in the order declared.
struct MonteCarloRun {
  const TrialKernel& kernel;
  const OutputSpec& spec;
  const McmSettings& settings;
  const double p;
  const int n_out, n_groups, n_tolerances;
  const SumLayout layout;
  const int stride;
  const bool adaptive;
  const std::int64_t batch_size;
  const std::vector<double> y0;
  const int threads;
  std::vector<Scratch> scratch;
  std::vector<std::vector<double>> buffers;
  const KeyedStream rng;
  // This rank's outputs (all of them without MPI): their values are stored here, their order
  // statistics computed here.
  const OutputShare share;
  const int own_first, n_own;
  const std::size_t bytes_per_trial;
  bool keep_all;
  // One process, fixed M, every value kept: the chunks write each value straight to its place in
  // `series` (sized here, not touched: UninitializedAllocator) instead of into a batch buffer that
  // one thread then appends.
  const bool direct;
  std::vector<ValueSeries> series;
  std::vector<double> total;
  std::vector<BatchStats> stats;             // filled for the own outputs
  std::vector<std::vector<double>> batch_k;  // own groups, when values are not all kept
  std::vector<Tails<float>> batch_tails;     // per-thread buffers of the batch endpoints
  const SumPlan sums;
  ProgressBar progress;
  const std::chrono::steady_clock::time_point t_start;
  std::int64_t done = 0;
  std::int64_t batches = 0;
  bool converged;
  std::vector<std::int64_t> convergence_trials;  // McmResult::convergence_*
  std::vector<double> convergence_ratio;

  MonteCarloRun(const TrialKernel& kernel, const OutputSpec& spec, const McmSettings& settings)
      : kernel(kernel),
        spec(spec),
        settings(settings),
        p(settings.coverage_probability),
        n_out(kernel.num_outputs()),
        n_groups(static_cast<int>(spec.groups.size())),
        n_tolerances(static_cast<int>(settings.tolerances.size())),
        layout(n_out, spec.groups, n_tolerances),
        stride(layout.stride()),
        adaptive(settings.trials == 0),
        batch_size(BatchSize(settings, adaptive)),
        y0(OutputsAtEstimates(kernel, spec)),
        threads(parallel_internal::ResolveThreads(settings.num_threads)),
        scratch(ThreadScratch(kernel, threads)),
        buffers(threads, std::vector<double>(static_cast<std::size_t>(n_out) * kSubBatch, 0.0)),
        rng(settings.seed),
        share(n_out, spec.groups),
        own_first(share.first),
        n_own(share.count()),
        bytes_per_trial(static_cast<std::size_t>(n_out) * sizeof(float)),
        keep_all(KeepsAllValues(settings, adaptive, bytes_per_trial)),
        direct(keep_all && !adaptive && ranks::Count() == 1),
        series(ValueStorage(n_own, keep_all, direct, adaptive, settings.trials)),
        total(stride, 0.0),
        stats(n_out),
        batch_k(n_groups),
        batch_tails(threads),
        sums(spec, n_out),
        progress("Monte Carlo", settings.quiet),
        t_start(std::chrono::steady_clock::now()),
        converged(!adaptive) {}

  // Items run on the process's shared workers (parallel/pool.h); `w` picks the per-thread scratch.
  void ParallelFor(int count, const std::function<void(int, int)>& fn) const {
    parallel_internal::ForEach(static_cast<std::size_t>(count), threads,
                               [&fn](std::size_t item, int w) { fn(static_cast<int>(item), w); });
  }

  void RunBatches();
  std::int64_t WaveSize() const;
  std::vector<Batch> NextWave() const;
  void ComputeWave(std::vector<Batch>& wave);
  void RunChunk(int c, int w, Batch& batch, const BatchExchange& exchange, std::vector<float>& computed);
  void WaveStatistics(std::vector<Batch>& wave);
  void BatchStatistics(Batch& batch, int i, int w);
  bool AccumulateWave(std::vector<Batch>& wave);
  template <class Destination>
  void AccumulateSubBatch(const double* out, int n, std::int64_t trial, const Destination& destination,
                          double* part) const;
  void AccumulateBatch(Batch& batch);
  void AddBatchSums(Batch& batch);
  void SwitchToBatchEndpoints(std::int64_t bh);
  void KeptBatchSums(std::int64_t b0, std::vector<float>& old, std::vector<double>& old_sums) const;
  void BatchExtras(std::vector<float>& vals, std::int64_t bh, const std::vector<double>& batch_sums);
  double WorstRatio() const;
  bool Finished(double worst);

  McmResult Result();
  McmResult Summary() const;
  std::vector<McmVectorResult> GroupResults(const McmResult& result) const;
  void FinalPass(McmResult& result, std::vector<McmVectorResult>& vectors);
  void SizeFinalExchange(FinalRecords& records) const;
  McmOutputResult::Histogram* HistogramOf(McmResult& result, int i) const;
  void AllValuesPass(McmResult& result, std::vector<McmVectorResult>& vectors);
  std::vector<const float*> RegionSeries(int gi, const McmVectorResult& r, Eigen::VectorXd* offset) const;
  void CoverageRegion(int gi, McmVectorResult& r) const;
  void SharedOrderStatistics(McmResult& result, std::vector<McmVectorResult>& vectors) const;
  void CountHistogramPass(McmResult& result, std::size_t item, std::int64_t passes,
                          std::vector<std::int64_t>& cells) const;
  void AddHistogramPasses(McmResult& result, std::int64_t passes,
                          const std::vector<std::int64_t>& cells) const;
  void AveragedEndpoints(McmResult& result, std::vector<McmVectorResult>& vectors) const;
  void PackOwnRecords(McmResult& result, const std::vector<McmVectorResult>& vectors,
                      FinalRecords& records) const;
  void ShareRecords(FinalRecords& records, McmResult& result, std::vector<McmVectorResult>& vectors) const;
  void SplitPointsAndVectors(McmResult& result, std::vector<McmVectorResult>& vectors) const;
};

void MonteCarloRun::RunBatches() {
  for (;;) {
    std::vector<Batch> wave = NextWave();
    ComputeWave(wave);
    WaveStatistics(wave);
    if (AccumulateWave(wave)) break;
  }
  progress.Finish();
}

// The batches of the next wave: kItemsPerThread items per thread in its parallel phases (the
// chunks, and the per-batch statistics of the own outputs), no batch past the run's end (fixed
// M) or past max_trials (adaptive), and no more values held for accumulation than kWaveBytes.
std::int64_t MonteCarloRun::WaveSize() const {
  const std::int64_t chunks_per_batch = (batch_size + kChunk - 1) / kChunk;
  // n_out, not this rank's outputs: every rank must compute the same waves (each batch is exchanged
  // and agreed on by all ranks together).
  const std::int64_t items_per_batch =
      std::max<std::int64_t>(1, std::min<std::int64_t>(chunks_per_batch, n_out));
  std::int64_t wave = (std::int64_t{kItemsPerThread} * threads + items_per_batch - 1) / items_per_batch;
  if (!direct) {
    const std::int64_t batch_bytes =
        std::int64_t{n_out} * batch_size * static_cast<std::int64_t>(sizeof(float));
    wave = std::min(wave, std::max<std::int64_t>(1, kWaveBytes / std::max<std::int64_t>(1, batch_bytes)));
  }
  const std::int64_t left = adaptive ? (settings.max_trials - done) / batch_size
                                     : (settings.trials - done + batch_size - 1) / batch_size;
  if (left <= wave || !direct) return std::max<std::int64_t>(1, std::min(wave, left));
  // Fixed M, values in place: the batches left in waves of at least `wave` batches, as equal as
  // can be, so that the last wave is not a short one with too few items for the threads.
  const std::int64_t waves_left = left / wave;
  return (left + waves_left - 1) / waves_left;
}

std::vector<Batch> MonteCarloRun::NextWave() const {
  std::vector<Batch> wave(static_cast<std::size_t>(WaveSize()));
  std::int64_t first = done;
  for (Batch& batch : wave) {
    batch.first = first;
    batch.bh = adaptive ? batch_size : std::min(batch_size, settings.trials - first);
    batch.n_chunks = static_cast<int>((batch.bh + kChunk - 1) / kChunk);
    batch.partial.assign(static_cast<std::size_t>(batch.n_chunks) * stride, 0.0);
    batch.batch_sums.assign(stride, 0.0);
    first += batch.bh;
  }
  return wave;
}

// This rank's chunks of every batch of the wave, for every output, as one parallel phase; a
// failure (a non-finite trial, no memory) is agreed with the other ranks before any of them waits
// for this rank's values. Each batch is then exchanged on its own (MPI).
void MonteCarloRun::ComputeWave(std::vector<Batch>& wave) {
  std::exception_ptr failure;
  bool computed_here = false;  // past this rank's chunks: a failure now was agreed or is alike on every rank
  try {
    std::vector<BatchExchange> exchanges;
    std::vector<std::vector<float>> computed(wave.size());
    std::vector<std::pair<int, int>> items;  // (batch, chunk) in trial order
    exchanges.reserve(wave.size());
    for (std::size_t b = 0; b < wave.size(); ++b) {
      Batch& batch = wave[b];
      const BatchExchange& exchange = exchanges.emplace_back(batch.n_chunks, stride, batch.bh, n_out, share);
      if (!direct) computed[b].resize(static_cast<std::size_t>(n_out) * exchange.trial_count);
      if (ranks::Count() > 1) batch.vals.resize(static_cast<std::size_t>(n_own) * batch.bh);
      for (int c = exchange.chunk_first; c < exchange.chunk_last; ++c)
        items.emplace_back(static_cast<int>(b), c);
    }
    std::mutex failures;
    ParallelFor(static_cast<int>(items.size()), [&](int item, int w) {
      const auto [b, c] = items[item];
      try {
        RunChunk(c, w, wave[b], exchanges[b], computed[b]);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(failures);
        if (c < wave[b].failed_chunk) wave[b].failed_chunk = c, wave[b].failure = std::current_exception();
      }
    });
    computed_here = true;
    kernel.TrialsRunBefore(wave.back().first + wave.back().bh);
    ranks::Agree();
    for (std::size_t b = 0; b < wave.size(); ++b) {
      exchanges[b].Exchange(wave[b].partial, stride, computed[b], wave[b].vals, wave[b].bh, n_own);
    }
  } catch (...) {
    if (computed_here) throw;
    failure = std::current_exception();
    ranks::Agree(failure);  // throws on every rank
  }
}

// Chunk c of the batch, on worker w: its sub-batches of trials in order, into the chunk's own sums.
void MonteCarloRun::RunChunk(int c, int w, Batch& batch, const BatchExchange& exchange,
                             std::vector<float>& computed) {
  const std::int64_t first = batch.first;
  const std::int64_t mine = exchange.trial_count;
  double* part = batch.partial.data() + static_cast<std::size_t>(c) * stride;
  double* out = buffers[w].data();
  const std::int64_t c0 = static_cast<std::int64_t>(c) * kChunk;
  const std::int64_t c1 = std::min<std::int64_t>(batch.bh, c0 + kChunk);
  for (std::int64_t s = c0; s < c1; s += kSubBatch) {
    const int n = static_cast<int>(std::min<std::int64_t>(kSubBatch, c1 - s));
    kernel.Run(rng, first + s, n, scratch[w], out);
    auto destination = [&](int o) {
      return direct ? series[o].data() + (first + s)
                    : computed.data() + static_cast<std::size_t>(o) * mine + (s - exchange.trial_first);
    };
    AccumulateSubBatch(out, n, first + s, destination, part);
  }
}

// The n trials of a sub-batch from `trial` (out[o * kSubBatch + i]): their deviations stored at
// destination(o), their sums added to the chunk's (`part`).
template <class Destination>
void MonteCarloRun::AccumulateSubBatch(const double* out, int n, std::int64_t trial,
                                       const Destination& destination, double* part) const {
  for (const int gi : sums.fused_groups) {
    const int o = spec.groups[gi].first;
    float* const dst[3] = {destination(o), destination(o + 1), destination(o + 2)};
    AccumulatePoint(o, gi, layout, out, n, y0, dst, part, trial, spec.names);
  }
  for (const int o : sums.single_outputs) {
    const double* row = out + static_cast<std::size_t>(o) * kSubBatch;
    float* dst = destination(o);
    double s1 = 0.0, s2 = 0.0;
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite(row[i])) NotFinite(trial + i, spec.names[o]);
      const double d = row[i] - y0[o];
      s1 += d;
      s2 += d * d;
      dst[i] = static_cast<float>(d);
    }
    part[layout.sum(o)] += s1;
    part[layout.sum2(o)] += s2;
  }
  for (const int gi : sums.other_groups) {
    AddCrossSums(spec.groups[gi], gi, layout, out, n, y0, part);
  }
  for (int t = 0; t < n_tolerances; ++t) {
    const McmSettings::ToleranceCount& tol = settings.tolerances[t];
    const double* row = out + static_cast<std::size_t>(tol.output) * kSubBatch;
    int inside = 0;
    for (int i = 0; i < n; ++i) inside += (row[i] >= tol.lower && row[i] <= tol.upper) ? 1 : 0;
    part[layout.count(t)] += inside;
  }
}

// Every batch's sums (its chunks' in chunk order), then 7.9.4 c), d) for every full batch and own
// output of the wave: one parallel phase of (batch, output) items.
void MonteCarloRun::WaveStatistics(std::vector<Batch>& wave) {
  for (Batch& batch : wave) {
    for (int c = 0; c < batch.n_chunks; ++c) {
      for (int k = 0; k < stride; ++k) {
        batch.batch_sums[k] += batch.partial[static_cast<std::size_t>(c) * stride + k];
      }
    }
    if (batch.bh == batch_size) batch.own_stats.resize(static_cast<std::size_t>(n_own) * kStatsPerOutput);
  }
  ParallelFor(static_cast<int>(wave.size()) * n_own, [&](int item, int w) {
    Batch& batch = wave[static_cast<std::size_t>(item / n_own)];
    // Only full batches count: the short last batch of a fixed-M run would weigh as much as a full one.
    if (batch.bh == batch_size && !batch.failure) BatchStatistics(batch, item % n_own, w);
  });
}

// The batches of the wave in trial order, each as if it were computed alone; true when the run
// ends (the batches after that one are dropped).
bool MonteCarloRun::AccumulateWave(std::vector<Batch>& wave) {
  for (Batch& batch : wave) {
    std::exception_ptr failure = batch.failure;
    try {
      if (!failure) AccumulateBatch(batch);
    } catch (...) {
      failure = std::current_exception();
    }
    ranks::Agree(failure);
    if (Finished(batch.worst)) return true;
  }
  return false;
}

// From here every rank holds the sums of every chunk and every value of its own outputs.
void MonteCarloRun::AccumulateBatch(Batch& batch) {
  AddBatchSums(batch);
  if (keep_all && static_cast<std::size_t>(done) * bytes_per_trial > settings.memory_budget_bytes) {
    SwitchToBatchEndpoints(batch.bh);
  }
  if (keep_all) {
    // (direct: the chunks wrote the values in place)
    for (int i = 0; !direct && i < n_own; ++i) {
      series[i].insert(series[i].end(), batch.vals.begin() + static_cast<std::size_t>(i) * batch.bh,
                       batch.vals.begin() + static_cast<std::size_t>(i + 1) * batch.bh);
    }
  } else if (batch.bh == batch_size) {
    BatchExtras(batch.vals, batch.bh, batch.batch_sums);
  }
  for (int i = 0; i < static_cast<int>(batch.own_stats.size()) / kStatsPerOutput; ++i) {
    const double* st = batch.own_stats.data() + static_cast<std::size_t>(i) * kStatsPerOutput;
    BatchStats& to = stats[own_first + i];
    to.mean.push_back(st[0]);
    to.u.push_back(st[1]);
    to.low.push_back(st[2]);
    to.high.push_back(st[3]);
  }
  // 7.9.4 e)-i): stop when 2 s <= delta for the mean, u, y_low and y_high of every output,
  // delta from u(y) of all h M values (this rank's outputs; the maximum over the ranks in Finished).
  if (adaptive && batches >= 2) batch.worst = WorstRatio();
}

// The batch's sums (WaveStatistics) into the run total in batch order.
void MonteCarloRun::AddBatchSums(Batch& batch) {
  for (int k = 0; k < stride; ++k) total[k] += batch.batch_sums[k];
  done += batch.bh;
  ++batches;
}

// Adaptive run outgrew the budget: switch to averaged batch endpoints, computing the batch
// extras of the batches kept so far, then drop the stored values.
void MonteCarloRun::SwitchToBatchEndpoints(std::int64_t bh) {
  keep_all = false;
  const std::int64_t kept = done - bh;
  for (std::int64_t b0 = 0; b0 < kept; b0 += batch_size) {
    std::vector<float> old(static_cast<std::size_t>(n_own) * batch_size);
    std::vector<double> old_sums(stride, 0.0);
    KeptBatchSums(b0, old, old_sums);
    BatchExtras(old, batch_size, old_sums);
  }
  series.clear();
  series.shrink_to_fit();
}

// The kept values of the batch from trial b0 copied to `old` ([o - own_first][trial]) and their
// sums (own outputs and groups) from the stored floats.
void MonteCarloRun::KeptBatchSums(std::int64_t b0, std::vector<float>& old,
                                  std::vector<double>& old_sums) const {
  for (int i = 0; i < n_own; ++i) {
    const int o = own_first + i;
    std::copy(series[i].begin() + b0, series[i].begin() + b0 + batch_size,
              old.begin() + static_cast<std::size_t>(i) * batch_size);
    for (std::int64_t t = 0; t < batch_size; ++t) {
      const double d = old[static_cast<std::size_t>(i) * batch_size + t];
      old_sums[layout.sum(o)] += d;
      old_sums[layout.sum2(o)] += d * d;
    }
  }
  for (const int gi : share.groups) {
    const OutputGroup& g = spec.groups[gi];
    const int l = g.first - own_first;
    for (int a = 0; a < g.dim; ++a) {
      for (int b = a + 1; b < g.dim; ++b) {
        double sum = 0.0;
        for (std::int64_t t = 0; t < batch_size; ++t) {
          sum += static_cast<double>(old[(l + a) * batch_size + t]) *
                 static_cast<double>(old[(l + b) * batch_size + t]);
        }
        old_sums[layout.cross(gi, PairIndex(a, b, g.dim))] += sum;
      }
    }
  }
}

// Batch statistics that need every value of a batch (shortest interval, k_p), for the
// averaged-endpoint method when not every value is kept. vals: [o - own_first][trial].
void MonteCarloRun::BatchExtras(std::vector<float>& vals, std::int64_t bh,
                                const std::vector<double>& batch_sums) {
  for (const int gi : share.groups) {
    const OutputGroup& g = spec.groups[gi];
    Eigen::VectorXd mean;
    Eigen::MatrixXd cov;
    GroupMoments(batch_sums, layout, g, gi, y0, bh, &mean, &cov);
    Eigen::VectorXd offset(g.dim);
    for (int a = 0; a < g.dim; ++a) offset(a) = mean(a) - y0[g.first + a];
    double k = 0.0;
    OutputGroup local = g;
    local.first -= own_first;
    if (RegionFactor(GroupSeries(vals.data(), bh, local), bh, offset, cov, p, threads, &k)) {
      batch_k[gi].push_back(k);
    }
  }
  ParallelFor(n_own, [&](int i, int) {
    const int o = own_first + i;
    CoverageInterval sym, shortest;
    CoverageIntervals(
        std::span<const float>(vals.data() + static_cast<std::size_t>(i) * bh, static_cast<std::size_t>(bh)),
        y0[o], p, &sym, &shortest);
    stats[o].shortest_low.push_back(shortest.low);
    stats[o].shortest_high.push_back(shortest.high);
  });
}

// 7.9.4 c), d): the batch's estimate, standard uncertainty and symmetric interval for own output
// i, on worker w, into batch.own_stats.
void MonteCarloRun::BatchStatistics(Batch& batch, int i, int w) {
  const std::int64_t bh = batch.bh;
  const double dbh = static_cast<double>(bh);
  const int o = own_first + i;
  double* st = batch.own_stats.data() + static_cast<std::size_t>(i) * kStatsPerOutput;
  const double s1 = batch.batch_sums[layout.sum(o)], s2 = batch.batch_sums[layout.sum2(o)];
  st[0] = y0[o] + s1 / dbh;
  st[1] = bh > 1 ? std::sqrt(std::max(0.0, (s2 - s1 * s1 / dbh) / (dbh - 1.0))) : 0.0;
  // y_(r) and y_(r+q) of 7.7.1: the largest of the r smallest values and the smallest of
  // the bh - r - q + 1 largest (mcm/order.h: one pass over the batch, then short sorts).
  const float* batch_values =
      direct ? series[i].data() + batch.first : batch.vals.data() + static_cast<std::size_t>(i) * bh;
  const std::int64_t q = CoverageCount(bh, p);
  const std::int64_t r = (bh - q) % 2 == 0 ? (bh - q) / 2 : (bh - q + 1) / 2;
  Tails<float>& tails = batch_tails[w];
  SortedTails(std::span<const float>(batch_values, static_cast<std::size_t>(bh)), r, bh - r - q + 1, &tails);
  st[2] = y0[o] + static_cast<double>(tails.low_values.back());
  st[3] = y0[o] + static_cast<double>(tails.high_values.front());
}

// The largest 2 s / delta of 7.9.4 g) over this rank's outputs.
double MonteCarloRun::WorstRatio() const {
  double worst = 0.0;
  const double dn = static_cast<double>(done);
  for (int o = own_first; o < share.last; ++o) {
    const double s1 = total[layout.sum(o)], s2 = total[layout.sum2(o)];
    const double u = std::sqrt(std::max(0.0, (s2 - s1 * s1 / dn) / (dn - 1.0)));
    const double delta = NumericalTolerance(u, settings.significant_digits);
    const double sd = std::max({StdOfAverage(stats[o].mean), StdOfAverage(stats[o].u),
                                StdOfAverage(stats[o].low), StdOfAverage(stats[o].high)});
    const double ratio = delta > 0.0 ? 2.0 * sd / delta : (sd > 0.0 ? 1e300 : 0.0);
    worst = std::max(worst, ratio);
  }
  return worst;
}

// Whether the run ends after this batch (adaptive: converged or the next batch would pass
// max_trials; fixed: M trials done); the progress shown either way.
bool MonteCarloRun::Finished(double worst) {
  const double dn = static_cast<double>(done);
  auto run_u = [&](int o) {
    const double s1 = total[layout.sum(o)], s2 = total[layout.sum2(o)];
    return done > 1 ? std::sqrt(std::max(0.0, (s2 - s1 * s1 / dn) / (dn - 1.0))) : 0.0;
  };
  std::string status;
  if (adaptive) {
    if (batches >= 2) {
      worst = mpi_internal::Max(worst);  // the largest over every output (exact)
      if (worst <= 1.0) converged = true;
      status = FormatStatus(worst, "worst 2s/delta (stops at <= 1):");
      convergence_trials.push_back(done);
      convergence_ratio.push_back(worst);
    }
    progress.Update(done, 0, status);
    return converged || done + batch_size > settings.max_trials;
  }
  double largest = 0.0;
  int worst_output = 0;
  for (int o = 0; o < n_out; ++o) {
    const double se = run_u(o) / std::sqrt(dn);
    if (se > largest) largest = se, worst_output = o;
  }
  progress.Update(done, settings.trials,
                  FormatStatus(largest, "largest std. error of a mean:") + " " + spec.units[worst_output] +
                      " (" + spec.names[worst_output] + ")");
  return done >= settings.trials;
}

McmResult MonteCarloRun::Result() {
  McmResult result = Summary();
  std::vector<McmVectorResult> vectors = GroupResults(result);
  FinalPass(result, vectors);
  SplitPointsAndVectors(result, vectors);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return result;
}

// The run and the summary statistics of every output (7.6), from the sums every rank holds.
McmResult MonteCarloRun::Summary() const {
  McmResult result;
  result.seed = settings.seed;
  result.coverage_probability = p;
  result.trials = done;
  result.adaptive = adaptive;
  result.converged = converged;
  result.batch_size = batch_size;
  result.batches = batches;
  result.convergence_trials = convergence_trials;
  result.convergence_ratio = convergence_ratio;
  result.threads = threads;
  result.ranks = ranks::Count();
  result.interval_method = keep_all ? "order statistics of all M values"
                                    : "average of the batch endpoints (memory budget exceeded)";
  const double dn = static_cast<double>(done);
  result.outputs.resize(n_out);
  for (int o = 0; o < n_out; ++o) {
    McmOutputResult& r = result.outputs[o];
    r.name = spec.names[o];
    r.unit = spec.units[o];
    r.value_at_estimates = y0[o];
    const double s1 = total[layout.sum(o)], s2 = total[layout.sum2(o)];
    r.mean = y0[o] + s1 / dn;
    r.u = std::sqrt(std::max(0.0, (s2 - s1 * s1 / dn) / (dn - 1.0)));
    for (int t = 0; t < n_tolerances; ++t) {
      if (settings.tolerances[t].output == o) r.conformity_probability = total[layout.count(t)] / dn;
    }
    r.accuracy.delta = NumericalTolerance(r.u, settings.significant_digits);
  }
  return result;
}

// Mean and covariance of every group, from the sums every rank holds.
std::vector<McmVectorResult> MonteCarloRun::GroupResults(const McmResult& result) const {
  std::vector<McmVectorResult> vectors(n_groups);
  for (int gi = 0; gi < n_groups; ++gi) {
    const OutputGroup& g = spec.groups[gi];
    McmVectorResult& r = vectors[gi];
    r.name = g.name;
    GroupMoments(total, layout, g, gi, y0, done, &r.mean, &r.covariance);
    for (int a = 0; a < g.dim; ++a) r.mean(a) = result.outputs[g.first + a].mean;
    r.correlation = model_internal::CorrelationOfCovariance(r.covariance);
  }
  return vectors;
}

// The order statistics of the own outputs and groups, then shared with every rank (the
// buffers allocated before the ranks agree that none failed).
void MonteCarloRun::FinalPass(McmResult& result, std::vector<McmVectorResult>& vectors) {
  FinalRecords records;
  records.own_outputs.resize(static_cast<std::size_t>(n_own) * kOutputRecord);
  records.own_groups.resize(share.groups.size() * kGroupRecord);
  std::exception_ptr failure;
  try {
    if (ranks::Count() > 1) SizeFinalExchange(records);
    if (keep_all) {
      AllValuesPass(result, vectors);
    } else {
      AveragedEndpoints(result, vectors);
    }
    PackOwnRecords(result, vectors, records);
  } catch (...) {
    failure = std::current_exception();
  }
  ranks::Agree(failure);
  if (ranks::Count() > 1) ShareRecords(records, result, vectors);
}

void MonteCarloRun::SizeFinalExchange(FinalRecords& records) const {
  for (int r = 0; r < ranks::Count(); ++r) {
    records.output_counts.push_back(static_cast<std::size_t>(share.last_of[r] - share.first_of[r]) *
                                    kOutputRecord);
    std::size_t groups_of_r = 0;
    for (const OutputGroup& g : spec.groups)
      groups_of_r += g.first >= share.first_of[r] && g.first < share.last_of[r];
    records.group_counts.push_back(groups_of_r * kGroupRecord);
  }
  records.all_outputs.resize(static_cast<std::size_t>(n_out) * kOutputRecord);
  records.all_groups.resize(static_cast<std::size_t>(n_groups) * kGroupRecord);
}

McmOutputResult::Histogram* MonteCarloRun::HistogramOf(McmResult& result, int i) const {
  McmOutputResult& out = result.outputs[own_first + i];
  return out.u > 0.0 && std::isfinite(out.u) ? &out.histogram : nullptr;
}

// The passes over all M stored values, each only reading them: the coverage region of every own
// group (JCGM 102 7.7.3), both coverage intervals of every own output (JCGM 101 7.7) and its
// histogram (McmOutputResult::histogram) in passes of kPassChunk values, the passes' counts added
// up per output afterwards (integers: exact in any order). With enough outputs for every thread,
// each region and pair of intervals is one item (the largest first); with few (one point: three
// outputs, one region), they are computed one after the other, each shared over the threads.
void MonteCarloRun::AllValuesPass(McmResult& result, std::vector<McmVectorResult>& vectors) {
  const std::size_t n_regions = share.groups.size();
  const std::int64_t passes = (done + kPassChunk - 1) / kPassChunk;
  std::vector<std::int64_t> cells(static_cast<std::size_t>(n_own * passes * kCells), 0);
  for (int i = 0; i < n_own; ++i) {
    if (McmOutputResult::Histogram* h = HistogramOf(result, i)) {
      const McmOutputResult& out = result.outputs[own_first + i];
      h->low = out.mean - 5.0 * out.u;
      h->width = 10.0 * out.u / kHistogramBins;
    }
  }
  auto intervals = [&](std::size_t i) {
    const int o = own_first + static_cast<int>(i);
    IntervalsAndTailIndex(series[i], y0[o], p, result.outputs[o]);
  };
  const bool item_per_output =
      n_regions + static_cast<std::size_t>(n_own) >= static_cast<std::size_t>(kItemsPerThread) * threads;
  if (!item_per_output) SharedOrderStatistics(result, vectors);
  const std::size_t n_first = item_per_output ? n_regions + static_cast<std::size_t>(n_own) : 0;
  const std::size_t n_items = n_first + static_cast<std::size_t>(n_own) * static_cast<std::size_t>(passes);
  parallel_internal::ForEach(n_items, threads, [&](std::size_t item, int) {
    if (item < n_first) {
      if (item < n_regions) {
        CoverageRegion(share.groups[item], vectors[share.groups[item]]);
      } else {
        intervals(item - n_regions);
      }
      return;
    }
    CountHistogramPass(result, item - n_first, passes, cells);
  });
  AddHistogramPasses(result, passes, cells);
}

// The inputs of the coverage region of group gi (JCGM 102 7.7.3): its components' stored values
// and its mean less y0.
std::vector<const float*> MonteCarloRun::RegionSeries(int gi, const McmVectorResult& r,
                                                      Eigen::VectorXd* offset) const {
  const OutputGroup& g = spec.groups[gi];
  offset->resize(g.dim);
  std::vector<const float*> components;
  for (int a = 0; a < g.dim; ++a) {
    (*offset)(a) = r.mean(a) - y0[g.first + a];
    components.push_back(series[g.first - own_first + a].data());
  }
  return components;
}

// k_p of the coverage region of group gi from all its stored values, on this thread.
void MonteCarloRun::CoverageRegion(int gi, McmVectorResult& r) const {
  Eigen::VectorXd offset;
  const std::vector<const float*> components = RegionSeries(gi, r, &offset);
  double k = 0.0;
  r.has_region = RegionFactor(components, done, offset, r.covariance, p, 1, &k);
  r.coverage_factor = r.has_region ? k : 0.0;
}

// Few outputs for the threads (one point: three outputs and one region): each pass over a series
// (the region's distances, the gathering of the tails) is shared over the threads, one series
// after the other; then the sorts of every tail run side by side (two per output; the region's one
// order statistic by a selection), then the endpoints and the tail index of each output (the
// shortest interval's scan over M - q values, Hill's sums) side by side (mcm/order.h: the same
// values as one item per output).
void MonteCarloRun::SharedOrderStatistics(McmResult& result, std::vector<McmVectorResult>& vectors) const {
  const int n_regions = static_cast<int>(share.groups.size());
  std::vector<Tails<double>> region_tails(static_cast<std::size_t>(n_regions));
  std::vector<char> has_region(static_cast<std::size_t>(n_regions), 0);
  for (int j = 0; j < n_regions; ++j) {
    const int gi = share.groups[j];
    Eigen::VectorXd offset;
    const std::vector<const float*> components = RegionSeries(gi, vectors[gi], &offset);
    has_region[j] =
        GatherRegionTail(components, done, offset, vectors[gi].covariance, p, threads, &region_tails[j]);
  }
  std::vector<Tails<float>> output_tails(static_cast<std::size_t>(n_own));
  for (int i = 0; i < n_own; ++i)
    GatherIntervalTails(std::span<const float>(series[i]), p, threads, &output_tails[i]);
  std::vector<double> region_k(static_cast<std::size_t>(n_regions), 0.0);
  ParallelFor(2 * n_own + n_regions, [&](int item, int) {
    if (item < 2 * n_own) {
      FinishTail(&output_tails[item / 2], item % 2);
    } else if (has_region[item - 2 * n_own]) {
      region_k[item - 2 * n_own] = SmallestOfHighTail(&region_tails[item - 2 * n_own]);
    }
  });
  for (int j = 0; j < n_regions; ++j) {
    McmVectorResult& r = vectors[share.groups[j]];
    r.has_region = has_region[j] != 0;
    r.coverage_factor = r.has_region ? region_k[j] : 0.0;
  }
  // Per output two items: its intervals, and its tail index (whether u means anything here,
  // McmOutputResult::tail_index); each writes its own fields.
  ParallelFor(2 * n_own, [&](int item, int) {
    const int i = item / 2;
    McmOutputResult& out = result.outputs[own_first + i];
    if (item % 2 == 0) {
      IntervalsFromTails(output_tails[i], done, y0[own_first + i], p, &out.symmetric, &out.shortest);
    } else {
      SetTailIndex(output_tails[i], done, y0[own_first + i], p, out);
    }
  });
}

// The histogram counts of one pass (item = own output i times passes + pass) into its cells.
void MonteCarloRun::CountHistogramPass(McmResult& result, std::size_t item, std::int64_t passes,
                                       std::vector<std::int64_t>& cells) const {
  const int i = static_cast<int>(static_cast<std::int64_t>(item) / passes);
  const std::int64_t pass = static_cast<std::int64_t>(item) % passes;
  const McmOutputResult::Histogram* h = HistogramOf(result, i);
  if (h == nullptr) return;
  std::int64_t* cell = cells.data() + static_cast<std::size_t>(item) * kCells;
  const std::int64_t first = pass * kPassChunk, end = std::min(done, first + kPassChunk);
  CountHistogram(std::span<const float>(series[i]).subspan(static_cast<std::size_t>(first),
                                                           static_cast<std::size_t>(end - first)),
                 y0[own_first + i], h->low, h->width, kHistogramBins, cell);
}

void MonteCarloRun::AddHistogramPasses(McmResult& result, std::int64_t passes,
                                       const std::vector<std::int64_t>& cells) const {
  for (int i = 0; i < n_own; ++i) {
    McmOutputResult::Histogram* h = HistogramOf(result, i);
    if (h == nullptr) continue;
    h->counts.assign(kHistogramBins, 0);
    for (std::int64_t pass = 0; pass < passes; ++pass) {
      const std::int64_t* cell = cells.data() + static_cast<std::size_t>(i * passes + pass) * kCells;
      for (int b = 0; b < kHistogramBins; ++b) h->counts[b] += cell[b];
      h->below += cell[kHistogramBins];
      h->above += cell[kHistogramBins + 1];
    }
  }
}

// Not every value kept: the averages of the batch endpoints and of the batches' k_p.
void MonteCarloRun::AveragedEndpoints(McmResult& result, std::vector<McmVectorResult>& vectors) const {
  for (const int gi : share.groups) {
    vectors[gi].has_region = !batch_k[gi].empty();
    vectors[gi].coverage_factor = Average(batch_k[gi]);
  }
  for (int o = own_first; o < share.last; ++o) {
    result.outputs[o].symmetric = {Average(stats[o].low), Average(stats[o].high)};
    result.outputs[o].shortest = {Average(stats[o].shortest_low), Average(stats[o].shortest_high)};
  }
}

// The own groups' regions and the own outputs' numerical accuracy (7.9.4), intervals and
// histograms into the records shared with the other ranks.
void MonteCarloRun::PackOwnRecords(McmResult& result, const std::vector<McmVectorResult>& vectors,
                                   FinalRecords& records) const {
  for (std::size_t j = 0; j < share.groups.size(); ++j) {
    const McmVectorResult& r = vectors[share.groups[j]];
    records.own_groups[j * kGroupRecord] = r.has_region ? 1.0 : 0.0;
    records.own_groups[j * kGroupRecord + 1] = r.coverage_factor;
  }
  for (int o = own_first; o < share.last; ++o) {
    McmNumericalAccuracy& a = result.outputs[o].accuracy;
    a.s_mean = StdOfAverage(stats[o].mean);
    a.s_u = StdOfAverage(stats[o].u);
    a.s_low = StdOfAverage(stats[o].low);
    a.s_high = StdOfAverage(stats[o].high);
    PackOutput(result.outputs[o],
               records.own_outputs.data() + static_cast<std::size_t>(o - own_first) * kOutputRecord);
  }
}

void MonteCarloRun::ShareRecords(FinalRecords& records, McmResult& result,
                                 std::vector<McmVectorResult>& vectors) const {
  mpi_internal::AllGather(std::span<const double>(records.own_outputs),
                          std::span<double>(records.all_outputs), records.output_counts);
  mpi_internal::AllGather(std::span<const double>(records.own_groups), std::span<double>(records.all_groups),
                          records.group_counts);
  for (int o = 0; o < n_out; ++o) {
    UnpackOutput(records.all_outputs.data() + static_cast<std::size_t>(o) * kOutputRecord, result.outputs[o]);
  }
  // The gathered group records follow the groups' order of their first output (OutputShare).
  std::vector<int> order(n_groups);
  for (int gi = 0; gi < n_groups; ++gi) order[gi] = gi;
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return spec.groups[a].first < spec.groups[b].first; });
  for (int j = 0; j < n_groups; ++j) {
    vectors[order[j]].has_region = records.all_groups[static_cast<std::size_t>(j) * kGroupRecord] != 0.0;
    vectors[order[j]].coverage_factor = records.all_groups[static_cast<std::size_t>(j) * kGroupRecord + 1];
  }
}

void MonteCarloRun::SplitPointsAndVectors(McmResult& result, std::vector<McmVectorResult>& vectors) const {
  for (int gi = 0; gi < n_groups; ++gi) {
    McmVectorResult& r = vectors[gi];
    if (spec.groups[gi].point) {
      McmPointResult pt;
      pt.name = r.name;
      pt.mean = r.mean;
      pt.covariance = r.covariance;
      pt.correlation = r.correlation;
      pt.has_region = r.has_region;
      pt.coverage_factor = r.coverage_factor;
      result.points.push_back(std::move(pt));
    } else {
      result.vectors.push_back(std::move(r));
    }
  }
}

}  // namespace

McmResult RunEngine(const TrialKernel& kernel, const OutputSpec& spec, const McmSettings& settings) {
  CheckSettings(kernel, settings);
  MonteCarloRun run(kernel, spec, settings);
  run.RunBatches();
  return run.Result();
}

}  // namespace vlt::mcm_internal
