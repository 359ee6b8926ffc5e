// mcm/engine.h — internals of the Monte Carlo engine shared by the job and custom-model entry
// points (vlt/mcm.h): input sampling (independent + Gaussian copula), the trial kernel
// interface, the batch/chunk/thread driver and the coverage-interval routines on stored values.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "gpu/trials.h"
#include "mcm/order.h"
#include "mcm/random.h"
#include "vlt/distributions.h"
#include "vlt/mcm.h"
#include "vlt/measurement_model.h"
#include "vlt/model_info.h"

namespace vlt::mcm_internal {

// Trials are evaluated in sub-batches of kSubBatch (structure-of-arrays buffers of this length)
// inside chunks of kChunk trials. Chunks are the unit of work of the threads and of the partial
// sums; their size never depends on the number of threads. 2500 divides the JCGM 101 7.9.4 batch
// of 10^4 trials (p <= 0.99) into 4 equal chunks, so that 2 threads get equal work.
inline constexpr int kSubBatch = 256;
inline constexpr int kChunk = 2500;

// Draws a vector of inputs for a range of trials: independent inputs by their own exact
// transforms, inputs with a non-zero correlation by a Gaussian copula (JCGM 101 6.4.8 for the
// normal case; other marginals through Phi and their inverse CDF). Input k uses random stream
// first_stream + k.
class InputSampler {
 public:
  // `correlation`: empty (independent) or size x size. `where` names the matrix in messages.
  // `t_groups`: inputs drawn jointly as a multivariate t (JCGM 102 6.5.3, Type A inputs from the
  // same simultaneous observations): their distributions must be normal with u the scale
  // s / sqrt(n); every member's correlated normal is divided by sqrt(w / nu), w ~ chi2_nu drawn
  // once per trial and group (stream kChiSquareStream + group).
  InputSampler(std::vector<Distribution> inputs, std::vector<std::string> names,
               const Eigen::MatrixXd& correlation, std::uint64_t first_stream, std::string_view where,
               std::span<const MultivariateTGroup> t_groups = {});

  int size() const { return static_cast<int>(inputs_.size()); }
  const std::vector<Distribution>& inputs() const { return inputs_; }
  // Doubles of scratch Draw needs for n trials.
  std::size_t scratch_size(int n) const { return copula_.size() * static_cast<std::size_t>(n); }

  // out[k * stride + i] = input k in trial first + i, i < n.
  void Draw(const KeyedStream& rng, std::int64_t first, int n, double* out, int stride,
            double* scratch) const;

 private:
  std::vector<Distribution> inputs_;
  std::vector<int> independent_;  // input indices drawn on their own
  std::vector<int> copula_;       // input indices drawn through the Gaussian copula
  Eigen::MatrixXd cholesky_;      // factor L L^T = R of the copula's correlation matrix: lower
                                  // triangular (Cholesky) unless R is singular (eigen factor)
  bool factor_is_lower_ = true;
  std::uint64_t first_stream_;
  std::vector<int> t_group_of_;  // per copula_ position: index into t_dof_, or -1
  std::vector<double> t_dof_;    // nu of each multivariate t group
};

// Random stream of the chi-square draw of multivariate t group g: kChiSquareStream + g, far above
// any input index.
inline constexpr std::uint64_t kChiSquareStream = std::uint64_t{1} << 40;

// A chi-square variate with nu > 0 degrees of freedom for one trial: 2 Gamma(nu / 2) by
// Marsaglia and Tsang's method (ACM TOMS 26 (2000) 363; shape < 1 through Gamma(a + 1) U^(1/a)),
// exact, its uniforms from KeyedStream::TrialUniforms(trial, stream, attempt).
double DrawChiSquare(const KeyedStream& rng, std::uint64_t stream, std::uint64_t trial, double nu);

// Normals for trials [first, first + n) of one stream: out[i] = z(trial first + i).
void DrawNormals(const KeyedStream& rng, std::uint64_t stream, std::int64_t first, int n, double* out);
// An input x ~ N(mean, u^2) for the same trials: out[i] = mean + u z(trial first + i), the
// scaling done as the normals are copied out (the same operations as scaling DrawNormals' out).
void DrawScaledNormals(const KeyedStream& rng, std::uint64_t stream, std::int64_t first, int n, double mean,
                       double u, double* out);

// Per-thread scratch owned by the driver, sized by the kernel.
struct Scratch {
  std::vector<double> doubles;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> task_outputs;
  // Job kernel: the shared inputs of each trial of a sub-batch prepared once
  // (MeasurementModel::PrepareShared), then used for every point.
  std::vector<MeasurementModel::PreparedShared> trial_states;
};

class TrialKernel {
 public:
  virtual ~TrialKernel() = default;
  virtual int num_outputs() const = 0;
  virtual void InitScratch(Scratch& scratch) const = 0;
  // The outputs at the input estimates (reference for the stored deviations).
  virtual std::vector<double> AtEstimates() const = 0;
  // outputs[o * kSubBatch + i] for trial first + i, i < n <= kSubBatch.
  virtual void Run(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch,
                   double* outputs) const = 0;
  // Every trial before `end` that this process runs has been run (the engine's wave is done; under
  // MPI a rank runs only its share of each batch): what the kernel holds for them may go.
  virtual void TrialsRunBefore(std::int64_t /*end*/) const {}
};

// A trial kernel whose trials the GPU kernel (gpu/point_trials.h) computes too, with the same
// bits: a tracker job's (mcm/job.cc JobKernel) or a custom model's (mcm/custom.cc CustomKernel).
// The GPU path (mcm/gpu_run.h) asks it for what the CPU prepares for the device and for the
// outputs computed from the device's.
class MirroredKernel : public TrialKernel {
 public:
  // What the GPU kernel takes from the CPU for trials first .. first + n - 1 (n <= kSubBatch),
  // drawn and prepared as Run draws and prepares them: with `stages`, each trial's (a tracker
  // job's air, pose, thermal stages); with `params`, the model's parameters, params[k stride + i]
  // for parameter k of trial first + i (gpu/point_trials.h DrawnParams).
  virtual void PrepareTrials(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch,
                             gpu_internal::TrialStages* stages, double* params, std::int64_t stride) const = 0;
  // The outputs after the device's (a tracker job's tasks) of trials 0 .. n - 1 of a sub-batch
  // whose device outputs are in place: the CPU's part of a trial the GPU computed.
  virtual void RunTasks(int n, Scratch& scratch, double* outputs) const = 0;
};

// Outputs that form one vector quantity (JCGM 102): a measured point (x, y, z) or the output
// vector of a custom model. Its covariance and coverage region are computed.
struct OutputGroup {
  std::string name;
  int first = 0;  // index of its first output; the others follow
  int dim = 3;
  bool point = true;  // true: reported in McmResult::points (dim 3), else McmResult::vectors
};

struct OutputSpec {
  std::vector<std::string> names;
  std::vector<std::string> units;
  std::vector<OutputGroup> groups;
};

McmResult RunEngine(const TrialKernel& kernel, const OutputSpec& spec, const McmSettings& settings);

// Both coverage intervals (JCGM 101 7.7) of the values `reference + values[i]` (partial sorts of
// the two tails only: O(M) + O((M - q) log(M - q))). `values` is only read. threads > 1: the pass
// over the values is shared over the workers (SortedTails); the intervals are the same.
void CoverageIntervals(std::span<const float> values, double reference, double p, CoverageInterval* symmetric,
                       CoverageInterval* shortest, int threads = 1);
void CoverageIntervals(std::span<const double> values, double reference, double p,
                       CoverageInterval* symmetric, CoverageInterval* shortest, int threads = 1);

// CoverageIntervals in steps, so that the passes and sorts of several outputs can share the
// threads (the engine's final pass): GatherIntervalTails (the pass over the values, mcm/order.h
// GatherTails), FinishTail(0) and (1) (the sorts; on any threads), then IntervalsFromTails (the
// endpoints; m values in all). The same intervals as CoverageIntervals.
template <typename T>
void GatherIntervalTails(std::span<const T> values, double p, int threads, Tails<T>* tails);
void IntervalsFromTails(const Tails<float>& tails, std::int64_t m, double reference, double p,
                        CoverageInterval* symmetric, CoverageInterval* shortest);

// Hill's estimator of the tail index from the sorted tails of M values (GatherIntervalTails +
// FinishTail; vlt/mcm.h McmOutputResult::tail_index), measured from `centre` (the middle of the
// probabilistically symmetric interval, in the tails' own terms):
//   alpha(k) = k / sum_{i=1..k} ln(X_(i) / X_(k+1)),  X = y - c (upper), c - y (lower), descending,
// the smaller of the two tails; infinity for a bounded tail. index = alpha(k1) with
// k1 = min(floor(kTailIndexFraction M), tail length - 1), absent when k1 < kTailIndexMinimumCount.
// infinite_variance: alpha (1 + 2 / sqrt(k)) < 2 at k1, k1 / 5 and k1 / 25 alike (decided only when
// k1 / 25 >= kTailIndexMinimumCount, M >= 2.5 10^5 at p <= 0.99).
struct TailIndexEstimate {
  std::optional<double> index;
  bool decided = false;
  bool infinite_variance = false;
};
TailIndexEstimate EstimateTailIndex(const Tails<float>& tails, std::int64_t m, double centre);
// McmOutputResult::tail_index and infinite_variance from the tails of the output's deviations
// from `reference`, measured from the middle of its probabilistically symmetric interval at p
// (computed here, so that this may run beside IntervalsFromTails).
void SetTailIndex(const Tails<float>& tails, std::int64_t m, double reference, double p, McmOutputResult& out);
// CoverageIntervals of one output's deviations and its tail index (one pass, one thread).
void IntervalsAndTailIndex(std::span<const float> values, double reference, double p, McmOutputResult& out);

// k_p of JCGM 102 7.7.3 from the deviations (float, relative to y0) of n trials of one group
// (mcm/region.cc): the q-th smallest |L^-1 (y_r - mean)|, L L^T = cov; series[a] holds
// component a, mean_minus_y0 the group's mean less y0. Returns false when the covariance is not
// positive definite.
bool RegionFactor(const std::vector<const float*>& series, std::int64_t n,
                  const Eigen::VectorXd& mean_minus_y0, const Eigen::MatrixXd& cov, double p, int threads,
                  double* k);
// RegionFactor in steps: the distances and the pass that gathers their high tail (false: the
// covariance is not positive definite), then k_p = SmallestOfHighTail(tails) (mcm/order.h).
bool GatherRegionTail(const std::vector<const float*>& series, std::int64_t n,
                      const Eigen::VectorXd& mean_minus_y0, const Eigen::MatrixXd& cov, double p, int threads,
                      Tails<double>* tails);

// The points' values of trials first .. first + n - 1 of `job` under `seed` as the CPU engine
// computes them (its job kernel, sub-batch by sub-batch): values[o * n + i], outputs o the x, y, z
// of every point (a task's are left out). The reference the GPU path is checked against, at run
// time (mcm/job.cc) and in tests/test_gpu_kernel.cc.
std::vector<double> JobTrialValues(const McmJob& job, std::uint64_t seed, std::int64_t first, int n);
// What the CPU prepares for a block of the GPU kernel's trials (docs/gpu.md): each trial's stages
// (air, pose, thermal; gpu/point_trials.h TrialStages) where the job has any, and the tracker
// parameters, params[k n + i] for parameter k of trial i, where the CPU draws them
// (PointTrialsJob::params_drawn). Empty where not prepared.
struct CpuTrialInputs {
  struct What {
    bool stages = false;
    int params = 0;  // the parameters drawn per trial (0: the kernel draws them)
    bool any() const { return stages || params > 0; }
  };
  // What the kernel's job takes from the CPU.
  static What For(const gpu_internal::PointTrialsJob& job);

  std::vector<gpu_internal::TrialStages> stages;
  std::vector<double> params;
  // The backend's view of them (gpu/trials.h).
  gpu_internal::PreparedTrials prepared() const;
};
// What the job kernel prepares for the GPU kernel's trials first .. first + n - 1 (`what` of it),
// drawn and prepared as the CPU engine draws and prepares them.
CpuTrialInputs JobTrialInputs(const McmJob& job, std::uint64_t seed, std::int64_t first, int n, CpuTrialInputs::What what);
// The same for a custom model (vlt/mcm.h RunMcmCustom's inputs): its outputs, values[o * n + i],
// and its inputs where the CPU draws them for the kernel (what.params), params[k n + i].
std::vector<double> CustomTrialValues(const ModelInfo& model, std::span<const UncertainInput> inputs,
                                      const Eigen::MatrixXd& correlation, std::uint64_t seed, std::int64_t first,
                                      int n);
CpuTrialInputs CustomTrialInputs(const ModelInfo& model, std::span<const UncertainInput> inputs,
                                 const Eigen::MatrixXd& correlation, std::uint64_t seed, std::int64_t first, int n,
                                 CpuTrialInputs::What what);

}  // namespace vlt::mcm_internal
