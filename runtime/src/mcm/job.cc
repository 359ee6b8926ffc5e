// mcm/job.cc — Monte Carlo over a laser tracker job (vlt/mcm.h RunMcm): shared inputs drawn
// once per trial (common to every point), readings per point, each point through the exact
// measurement model, then each task from the drawn points.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "gpu/trials.h"
#include "mcm/engine.h"
#include "vlt/error.h"
#include "vlt/fits.h"
#include "vlt/mcm.h"

namespace vlt {
namespace {

using mcm_internal::InputSampler;
using mcm_internal::KeyedStream;
using mcm_internal::kSubBatch;
using mcm_internal::Scratch;

std::vector<Distribution> SharedDistributions(const MeasurementModel& model) {
  std::vector<Distribution> out;
  for (const UncertainInput& input : model.shared_inputs()) {
    out.push_back(Distribution::FromInput(input, "Monte Carlo input"));
  }
  return out;
}

std::vector<std::string> SharedNames(const MeasurementModel& model) {
  std::vector<std::string> out;
  for (const UncertainInput& input : model.shared_inputs()) out.push_back(input.name);
  return out;
}

class JobKernel final : public mcm_internal::TrialKernel {
 public:
  explicit JobKernel(const McmJob& job)
      : model_(*job.model),
        job_(job),
        shared_(SharedDistributions(model_), SharedNames(model_), model_.shared_correlation(), 0,
                "measurement setup: correlation of the shared inputs"),
        num_shared_(model_.num_shared()),
        lanes_params_(model_.has_forward_lanes() ? model_.setup().model->num_params : 0) {
    n_out_ = 3 * static_cast<int>(job.points.size());
    for (const McmPoint& point : job.points) {
      const Eigen::Vector3d u = model_.reading_uncertainty(point.readings(0));
      if (!(u.minCoeff() >= 0.0) || !u.allFinite()) {
        throw InputError("Monte Carlo: point '" + point.name +
                         "': reading uncertainty must be finite and >= 0");
      }
      reading_u_.push_back(u);
    }
    for (const McmTask& task : job.tasks) {
      if (task.output_names.size() != task.output_units.size() || !task.evaluate) {
        throw InputError("Monte Carlo: task '" + task.name + "' is incomplete");
      }
      for (int index : task.points) {
        if (index < 0 || index >= static_cast<int>(job.points.size())) {
          throw InputError("Monte Carlo: task '" + task.name + "' refers to point index " +
                           std::to_string(index) + " (job has " + std::to_string(job.points.size()) +
                           " points)");
        }
      }
      task_first_output_.push_back(n_out_);
      n_out_ += static_cast<int>(task.output_names.size());
      max_task_points_ = std::max(max_task_points_, task.points.size());
      max_task_outputs_ = std::max(max_task_outputs_, task.output_names.size());
    }
  }

  int num_outputs() const override { return n_out_; }

  void InitScratch(Scratch& scratch) const override {
    const std::size_t s = static_cast<std::size_t>(num_shared_);
    // shared SoA | shared AoS | copula scratch | readings SoA (3) | parameters in lanes
    scratch.doubles.assign(2 * s * kSubBatch + shared_.scratch_size(kSubBatch) +
                               3 * static_cast<std::size_t>(kSubBatch) +
                               static_cast<std::size_t>(lanes_params_) * kForwardLanes,
                           0.0);
    scratch.trial_states.assign(kSubBatch, MeasurementModel::PreparedShared{});
    scratch.points.assign(std::max<std::size_t>(max_task_points_, 1), Eigen::Vector3d::Zero());
    scratch.task_outputs.assign(std::max<std::size_t>(max_task_outputs_, 1), 0.0);
  }

  std::vector<double> AtEstimates() const override {
    const Eigen::VectorXd shared = model_.shared_estimates();
    std::vector<double> out(n_out_);
    for (std::size_t p = 0; p < job_.points.size(); ++p) {
      model_.Evaluate(job_.points[p].readings.data(), shared.data(), &out[3 * p]);
    }
    std::vector<Eigen::Vector3d> points;
    for (std::size_t t = 0; t < job_.tasks.size(); ++t) {
      const McmTask& task = job_.tasks[t];
      points.clear();
      for (int index : task.points) {
        points.emplace_back(out[3 * index], out[3 * index + 1], out[3 * index + 2]);
      }
      task.evaluate(points, std::span<double>(out.data() + task_first_output_[t], task.output_names.size()));
    }
    return out;
  }

  void Run(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch,
           double* outputs) const override {
    const int s_count = num_shared_;
    double* shared_soa = scratch.doubles.data();
    double* shared_aos = shared_soa + static_cast<std::size_t>(s_count) * kSubBatch;
    double* copula = shared_aos + static_cast<std::size_t>(s_count) * kSubBatch;
    double* readings = copula + shared_.scratch_size(kSubBatch);
    double* params_lanes = readings + 3 * kSubBatch;
    MeasurementModel::PreparedShared* states = scratch.trial_states.data();
    // Without air, pose or thermal stage the lanes kernel reads nothing prepared (y = x_t).
    DrawShared(rng, first, n, scratch, lanes_params_ == 0 || model_.has_shared_stages());

    const std::uint64_t first_reading_stream = static_cast<std::uint64_t>(s_count);
    for (std::size_t p = 0; p < job_.points.size(); ++p) {
      const Eigen::Vector3d& estimate = job_.points[p].readings;
      const Eigen::Vector3d& u = reading_u_[p];
      for (int j = 0; j < 3; ++j) {
        double* row = readings + j * kSubBatch;
        mcm_internal::DrawScaledNormals(rng, first_reading_stream + 3 * p + j, first, n, estimate(j), u(j), row);
      }
      double* out_x = outputs + 3 * p * kSubBatch;
      // kForwardLanes trials at a time through the model's SIMD kernel (the last group padded
      // with the sub-batch's last trial, whose extra results are dropped: every lane is computed
      // on its own, so a trial's value does not depend on its neighbours); the double kernel per
      // trial for a model without one.
      constexpr int kL = kForwardLanes;
      if (lanes_params_ > 0) {
        for (int i = 0; i < n; i += kL) {
          const MeasurementModel::PreparedShared* lane_states[kL];
          double r[3 * kL], y[3 * kL];
          if (i + kL <= n) {
            // A whole group: each row's kL trials are already side by side.
            for (int l = 0; l < kL; ++l) lane_states[l] = &states[i + l];
            for (int j = 0; j < 3; ++j) std::memcpy(r + kL * j, readings + j * kSubBatch + i, sizeof(double) * kL);
            for (int k = 0; k < lanes_params_; ++k) {
              std::memcpy(params_lanes + kL * k, shared_soa + static_cast<std::size_t>(k) * kSubBatch + i,
                          sizeof(double) * kL);
            }
          } else {
            LastGroupLanes(i, n, shared_soa, readings, states, lane_states, r, params_lanes);
          }
          model_.EvaluatePreparedLanes(lane_states, r, params_lanes, y);
          const int kept = std::min(kL, n - i);
          for (int j = 0; j < 3; ++j) std::memcpy(out_x + j * kSubBatch + i, y + kL * j, sizeof(double) * kept);
        }
      } else {
        for (int i = 0; i < n; ++i) {
          const double r[3] = {readings[i], readings[kSubBatch + i], readings[2 * kSubBatch + i]};
          double y[3];
          model_.EvaluatePrepared(states[i], r, y);
          out_x[i] = y[0];
          out_x[kSubBatch + i] = y[1];
          out_x[2 * kSubBatch + i] = y[2];
        }
      }
    }

    RunTasks(n, scratch, outputs);
  }

  // What the GPU kernel takes from the CPU for trials first .. first + n - 1 (n <= kSubBatch),
  // drawn and prepared as Run draws and prepares them: with `stages`, each trial's
  // (gpu/point_trials.h TrialStages); with `params`, the tracker model's parameters,
  // params[k stride + i] for parameter k of trial first + i (DrawnParams).
  void PrepareTrials(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch,
                     gpu_internal::TrialStages* stages, double* params, std::int64_t stride) const {
    DrawShared(rng, first, n, scratch, stages != nullptr);
    for (int i = 0; stages != nullptr && i < n; ++i) {
      const MeasurementModel::PreparedShared& state = scratch.trial_states[static_cast<std::size_t>(i)];
      gpu_internal::TrialStages& trial = stages[i];
      trial.range_scale = state.range_scale;
      std::copy(state.rotation.data(), state.rotation.data() + 9, trial.rotation);
      std::copy(state.translation.data(), state.translation.data() + 3, trial.translation);
      trial.thermal_scale = state.thermal_scale;
    }
    // The sampler's rows of the parameters: the values Run hands the lanes kernel.
    const double* shared_soa = scratch.doubles.data();
    for (int k = 0; params != nullptr && k < lanes_params_; ++k) {
      const double* row = shared_soa + static_cast<std::size_t>(k) * kSubBatch;
      std::copy(row, row + n, params + k * stride);
    }
  }

 private:
  // Shared inputs: drawn once per trial, common to every point, into the scratch's structure of
  // arrays. With `prepare`, each trial's vector of them is copied out for PrepareShared and the
  // scalar kernel — with the lanes kernel, which takes the tracker model's parameters from the
  // draws directly, only the inputs after them (air, pose, thermal) — and its stages prepared
  // into scratch.trial_states.
  void DrawShared(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch, bool prepare) const {
    const int s_count = num_shared_;
    double* shared_soa = scratch.doubles.data();
    double* shared_aos = shared_soa + static_cast<std::size_t>(s_count) * kSubBatch;
    double* copula = shared_aos + static_cast<std::size_t>(s_count) * kSubBatch;
    shared_.Draw(rng, first, n, shared_soa, kSubBatch, copula);
    for (int i = 0; prepare && i < n; ++i) {
      double* aos = shared_aos + static_cast<std::size_t>(i) * s_count;
      for (int k = lanes_params_; k < s_count; ++k)
        aos[k] = shared_soa[static_cast<std::size_t>(k) * kSubBatch + i];
      // Air index, pose and thermal scale depend on the shared inputs only: once per trial,
      // not once per point (states[i] refers to aos, which stays put until the sub-batch ends).
      scratch.trial_states[static_cast<std::size_t>(i)] = model_.PrepareShared(aos);
    }
  }

  // The sub-batch's last, short group of trials i .. n - 1 in lanes, padded with trial n - 1.
  void LastGroupLanes(int i, int n, const double* shared_soa, const double* readings,
                      const MeasurementModel::PreparedShared* states,
                      const MeasurementModel::PreparedShared** lane_states, double* r,
                      double* params_lanes) const {
    constexpr int kL = kForwardLanes;
    int trial[kL];
    for (int l = 0; l < kL; ++l) {
      trial[l] = std::min(i + l, n - 1);
      lane_states[l] = &states[trial[l]];
      for (int j = 0; j < 3; ++j) r[kL * j + l] = readings[j * kSubBatch + trial[l]];
    }
    for (int k = 0; k < lanes_params_; ++k) {
      const double* row = shared_soa + static_cast<std::size_t>(k) * kSubBatch;
      for (int l = 0; l < kL; ++l) params_lanes[kL * k + l] = row[trial[l]];
    }
  }

 public:
  // The tasks' outputs of trials 0 .. n - 1 of a sub-batch from its points' outputs (the fit is
  // part of the propagated model): the CPU's part of a trial whose points a GPU computed too.
  void RunTasks(int n, Scratch& scratch, double* outputs) const {
    for (std::size_t t = 0; t < job_.tasks.size(); ++t) {
      const McmTask& task = job_.tasks[t];
      const std::size_t np = task.points.size(), no = task.output_names.size();
      for (int i = 0; i < n; ++i) {
        for (std::size_t k = 0; k < np; ++k) {
          const double* x = outputs + 3 * static_cast<std::size_t>(task.points[k]) * kSubBatch + i;
          scratch.points[k] = Eigen::Vector3d(x[0], x[kSubBatch], x[2 * kSubBatch]);
        }
        task.evaluate(std::span<const Eigen::Vector3d>(scratch.points.data(), np),
                      std::span<double>(scratch.task_outputs.data(), no));
        for (std::size_t k = 0; k < no; ++k) {
          outputs[(task_first_output_[t] + k) * kSubBatch + i] = scratch.task_outputs[k];
        }
      }
    }
  }

 private:
  const MeasurementModel& model_;
  const McmJob& job_;
  InputSampler shared_;
  int num_shared_;
  int lanes_params_;  // the tracker model's parameters when it has a lanes kernel, else 0
  int n_out_ = 0;
  std::vector<Eigen::Vector3d> reading_u_;
  std::vector<int> task_first_output_;
  std::size_t max_task_points_ = 0;
  std::size_t max_task_outputs_ = 0;
};

// The fit tasks as McmTasks calling FitTask; normals / directions oriented like the fit at the
// estimates (vlt/fits.h FitOptions::orientation).
std::vector<McmTask> FitTasks(const McmJob& job) {
  if (job.fit_task_points.size() != job.fit_tasks.size()) {
    throw InputError("Monte Carlo: fit_task_points must have one list per fit task");
  }
  std::vector<McmTask> out;
  const Eigen::VectorXd shared = job.model->shared_estimates();
  for (std::size_t t = 0; t < job.fit_tasks.size(); ++t) {
    const TaskSpec& spec = job.fit_tasks[t];
    McmTask task;
    task.name = spec.name;
    task.points = job.fit_task_points[t];
    Eigen::Matrix3Xd estimates(3, task.points.size());
    for (std::size_t k = 0; k < task.points.size(); ++k) {
      const int index = task.points[k];
      if (index < 0 || index >= static_cast<int>(job.points.size())) {
        throw InputError("Monte Carlo: task '" + spec.name + "' refers to point index " +
                         std::to_string(index));
      }
      job.model->Evaluate(job.points[index].readings.data(), shared.data(),
                          estimates.col(static_cast<Eigen::Index>(k)).data());
    }
    const std::string where = "task '" + spec.name + "'";
    FitOptions at_estimates = TaskFitOptions(spec, false);
    if (spec.weighted) {
      if (t >= job.fit_task_covariance.size() || job.fit_task_covariance[t] == nullptr) {
        throw InputError("Monte Carlo: task '" + spec.name +
                         "' is weighted by its points' covariance: give it (McmJob::fit_task_covariance)");
      }
      at_estimates.covariance = job.fit_task_covariance[t];
    }
    const FitResult nominal = FitTask(spec.kind, estimates, at_estimates, where);
    const FitOptions options = TrialFitOptions(spec, nominal.values, nominal.weights);
    for (const TaskOutput& output : TaskOutputs(spec.kind)) {
      task.output_names.push_back(spec.name + "." + std::string(output.name));
      task.output_units.emplace_back(output.unit);
    }
    const TaskKind kind = spec.kind;
    task.evaluate = [kind, options, where](std::span<const Eigen::Vector3d> points,
                                           std::span<double> values) {
      const Eigen::Map<const Eigen::Matrix3Xd> matrix(points.data()->data(), 3,
                                                      static_cast<Eigen::Index>(points.size()));
      const FitResult fit = FitTask(kind, matrix, options, where);
      for (std::size_t k = 0; k < values.size(); ++k) values[k] = fit.values(static_cast<Eigen::Index>(k));
    };
    out.push_back(std::move(task));
  }
  return out;
}

// What the GPU kernel takes from the CPU for trials first .. first + n - 1 (what.stages: the
// stages — air, pose, thermal; what.params: the tracker parameters, num_params of them), sized.
mcm_internal::CpuTrialInputs SizedInputs(mcm_internal::CpuTrialInputs::What what, int n) {
  mcm_internal::CpuTrialInputs inputs;
  if (what.stages) inputs.stages.resize(static_cast<std::size_t>(n));
  inputs.params.resize(static_cast<std::size_t>(what.params) * static_cast<std::size_t>(n));
  return inputs;
}

// Sub-batch k (trials first + k kSubBatch .., at most kSubBatch of the n) of `inputs`, drawn and
// prepared by the job kernel's own code. With `unprepared`, a sub-batch whose stages fail (a drawn
// humidity past 100 %: an error of the job's own inputs) is marked there, (*unprepared)[k] = 1,
// instead of failing: a block holds trials the run may never use (past M, after an adaptive run
// stops), and where the run does use them the CPU path computes them and says what is wrong, at
// the trial it is wrong.
void PrepareSubBatch(const JobKernel& cpu, const KeyedStream& rng, std::int64_t first, int n, int k, Scratch& scratch,
                     mcm_internal::CpuTrialInputs& inputs, std::vector<char>* unprepared) {
  const int done = k * kSubBatch;
  const int count = std::min(kSubBatch, n - done);
  gpu_internal::TrialStages* stages = inputs.stages.empty() ? nullptr : inputs.stages.data() + done;
  double* params = inputs.params.empty() ? nullptr : inputs.params.data() + done;
  try {
    cpu.PrepareTrials(rng, first + done, count, scratch, stages, params, n);
  } catch (const std::exception&) {
    if (unprepared == nullptr) throw;
    (*unprepared)[static_cast<std::size_t>(k)] = 1;
    if (stages != nullptr) std::fill(stages, stages + count, gpu_internal::TrialStages{});
  }
}

int SubBatches(int n) { return (n + kSubBatch - 1) / kSubBatch; }

// Trials first .. first + n - 1 prepared on this thread (the run-time check and the tests).
mcm_internal::CpuTrialInputs InputsOfTrials(const JobKernel& cpu, const KeyedStream& rng, std::int64_t first, int n,
                                            Scratch& scratch, mcm_internal::CpuTrialInputs::What what) {
  mcm_internal::CpuTrialInputs inputs = SizedInputs(what, n);
  for (int k = 0; k < SubBatches(n); ++k) PrepareSubBatch(cpu, rng, first, n, k, scratch, inputs, nullptr);
  return inputs;
}

// What the CPU prepares for one block of a GPU run (InputsOfTrials' sub-batches), shared by the
// engine's threads: each thread that needs the block prepares sub-batches until none is left, then
// waits for the block's values; the thread that computes the block hands them to the device once
// all are prepared. (Before, the computing thread prepared the whole block while the others waited,
// so one thread's rate bounded any GPU run: 6.5 M trials/s with the air on the 2-core machine of
// docs/performance.md §4.15.) The draws depend on the trial only, so which thread prepares a
// sub-batch changes no bit.
class SharedPreparation {
 public:
  SharedPreparation(mcm_internal::CpuTrialInputs::What what, std::int64_t first, int n)
      : what_(what), first_(first), n_(n), sub_batches_(SubBatches(n)) {}

  // The block's buffers, sized by the thread that computes it (outside the kernel's lock); every
  // helper waits for them. A failure leaves nothing to prepare.
  void Allocate() {
    bool sized = true;
    try {
      inputs_ = SizedInputs(what_, n_);
      unprepared_.assign(static_cast<std::size_t>(sub_batches_), 0);
    } catch (...) {
      sized = false;
    }
    const std::lock_guard<std::mutex> lock(mutex_);
    allocated_ = true;
    if (!sized) prepared_ = sub_batches_ = 0;
    changed_.notify_all();
  }

  // Prepares sub-batches not yet taken, in `scratch` (the calling thread's).
  void Help(const JobKernel& cpu, const KeyedStream& rng, Scratch& scratch) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [this] { return allocated_; });
    }
    for (int k = next_.fetch_add(1); k < sub_batches_; k = next_.fetch_add(1)) {
      try {
        PrepareSubBatch(cpu, rng, first_, n_, k, scratch, inputs_, &unprepared_);
      } catch (...) {
        unprepared_[static_cast<std::size_t>(k)] = 1;  // counted all the same: no thread waits forever
      }
      const std::lock_guard<std::mutex> lock(mutex_);
      if (++prepared_ == sub_batches_) changed_.notify_all();
    }
  }

  // Waits until every sub-batch is prepared; false if the buffers could not be allocated.
  bool Wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [this] { return allocated_ && prepared_ == sub_batches_; });
    return sub_batches_ > 0;
  }

  const mcm_internal::CpuTrialInputs& inputs() const { return inputs_; }
  // After the device took the inputs (every sub-batch prepared, so no thread writes them): the
  // sub-batches that could not be prepared; the inputs are freed.
  std::vector<char> Release() {
    inputs_ = {};
    return std::move(unprepared_);
  }

 private:
  mcm_internal::CpuTrialInputs::What what_;
  std::int64_t first_;
  int n_;
  int sub_batches_;
  mcm_internal::CpuTrialInputs inputs_;
  std::vector<char> unprepared_;  // written per sub-batch by its thread (distinct bytes)
  std::atomic<int> next_{0};
  std::mutex mutex_;
  std::condition_variable changed_;
  bool allocated_ = false;
  int prepared_ = 0;
};

// A block of trials computed by a backend: values[o * n + i], and the sub-batches whose stages the
// CPU could not prepare (InputsOfTrials), whose values are not the trials'.
struct BlockValues {
  std::vector<double> values;
  std::vector<char> unprepared;
};


// The job's trials on a GPU (docs/gpu.md): the points' values of each trial from the device
// (gpu/point_trials.h: the same draws and model as JobKernel::Run, the same bits), the tasks from
// them on the CPU by JobKernel's own code. The device computes blocks of block_ trials, one block
// at a time; the engine's threads ask for sub-batches (at most kSubBatch trials, anywhere in a
// block) and copy theirs out of the block that holds them. A block is computed by the first thread
// that needs it and forgotten once all its trials were copied out.
class GpuJobKernel final : public mcm_internal::TrialKernel {
 public:
  // Most bytes of values and of what the CPU prepares a block holds (kSubBatch trials at least:
  // KernelJob refuses more points).
  static constexpr std::int64_t kBlockBytes = std::int64_t{64} << 20;
  using What = mcm_internal::CpuTrialInputs::What;

  // what: the stages and parameters the CPU prepares for the kernel (KernelJob). trials: the
  // run's M (0: adaptive). fall_back: on a GPU failure during the run, compute the remaining
  // trials on the CPU (the same bits; McmDevice::kAuto) instead of failing.
  GpuJobKernel(const McmJob& job, std::unique_ptr<gpu_internal::TrialsBackend> backend, What what,
               std::int64_t trials, bool fall_back)
      : cpu_(job), backend_(std::move(backend)), point_outputs_(3 * static_cast<int>(job.points.size())),
        what_(what), fall_back_(fall_back) {
    // An eighth of M a block (the device busy while the engine's threads copy out the previous
    // one), at least 4096 trials, at most 2^20 and kBlockBytes of values, stages and parameters.
    const std::int64_t fit = kBlockBytes / BytesPerTrial(static_cast<int>(job.points.size()), what_);
    const std::int64_t wanted = trials > 0 ? std::max<std::int64_t>(4096, (trials + 7) / 8) : std::int64_t{1} << 20;
    block_ = std::max<std::int64_t>(kSubBatch, std::min({wanted, std::int64_t{1} << 20, fit}));
  }

  // A trial's values in a block, and what the CPU prepares for it.
  static std::int64_t BytesPerTrial(int points, What what) {
    return 3 * 8 * std::int64_t{std::max(1, points)} + PreparedBytes(what);
  }
  // The most points whose kSubBatch trials (the least a block holds) fit in kBlockBytes.
  static std::int64_t MostPoints(What what) { return (kBlockBytes / kSubBatch - PreparedBytes(what)) / (3 * 8); }

  int num_outputs() const override { return cpu_.num_outputs(); }
  void InitScratch(Scratch& scratch) const override { cpu_.InitScratch(scratch); }
  std::vector<double> AtEstimates() const override { return cpu_.AtEstimates(); }

 private:
  static std::int64_t PreparedBytes(What what) {
    const std::int64_t stages = what.stages ? static_cast<std::int64_t>(sizeof(gpu_internal::TrialStages)) : 0;
    return stages + 8 * std::int64_t{what.params};
  }

 public:

  void Run(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch, double* outputs) const override {
    if (failed_.load()) return cpu_.Run(rng, first, n, scratch, outputs);
    bool from_blocks = false;
    try {
      from_blocks = CopyFromBlocks(rng, first, n, scratch, outputs);
    } catch (const std::exception& e) {
      if (!fall_back_) throw;
      Fail(e.what());
      return cpu_.Run(rng, first, n, scratch, outputs);
    }
    // Trials whose stages the CPU could not prepare: the CPU path computes them, or says what is
    // wrong with the job's inputs (not the GPU's failure).
    if (!from_blocks) return cpu_.Run(rng, first, n, scratch, outputs);
    cpu_.RunTasks(n, scratch, outputs);
  }

  std::string Description() const { return backend_->Description(); }
  // Why the trials after the GPU failed ran on the CPU; "" when it did not fail.
  std::string failure() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return failure_;
  }

 private:
  using Values = std::shared_ptr<const BlockValues>;
  struct Entry {
    std::shared_future<Values> values;
    std::shared_ptr<SharedPreparation> preparation;  // nullptr where the CPU prepares nothing
    std::int64_t left = 0;                           // trials not yet copied out
  };

  // Copies trials first .. first + n - 1 out of their blocks; false when some of them had stages
  // the CPU could not prepare (their blocks' trials are counted as copied out all the same).
  bool CopyFromBlocks(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch, double* outputs) const {
    bool prepared = true;
    for (int done = 0; done < n;) {
      const std::int64_t trial = first + done;
      const std::int64_t index = trial / block_;
      const Values block = Block(index, rng, scratch);
      const std::int64_t offset = trial - index * block_;
      const int count = static_cast<int>(std::min<std::int64_t>(n - done, block_ - offset));
      for (std::int64_t k = offset / kSubBatch; !block->unprepared.empty() && k <= (offset + count - 1) / kSubBatch; ++k) {
        prepared = prepared && block->unprepared[static_cast<std::size_t>(k)] == 0;
      }
      for (int o = 0; prepared && o < point_outputs_; ++o) {
        const double* from =
            block->values.data() + static_cast<std::size_t>(o) * static_cast<std::size_t>(block_) + offset;
        std::copy(from, from + count, outputs + static_cast<std::size_t>(o) * kSubBatch + done);
      }
      CopiedOut(index, count);
      done += count;
    }
    return prepared;
  }

  // Block `index`'s values (values[o * block_ + i]), computed once, one block at a time on the
  // device; what the CPU prepares for it shared by every thread that needs the block
  // (SharedPreparation, each in its own scratch) before the thread that computes it hands it over.
  Values Block(std::int64_t index, const KeyedStream& rng, Scratch& scratch) const {
    std::promise<Values> promise;
    std::shared_future<Values> future;
    std::shared_ptr<SharedPreparation> preparation;
    bool compute = false;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      auto it = blocks_.find(index);
      if (it == blocks_.end()) {
        future = promise.get_future().share();
        if (what_.any()) {
          preparation = std::make_shared<SharedPreparation>(what_, index * block_, static_cast<int>(block_));
        }
        blocks_.emplace(index, Entry{future, preparation, block_});
        compute = true;
      } else {
        future = it->second.values;
        preparation = it->second.preparation;
      }
    }
    if (compute && preparation) preparation->Allocate();
    if (preparation) preparation->Help(cpu_, rng, scratch);
    if (compute) {
      try {
        promise.set_value(Compute(index, preparation.get()));
      } catch (...) {
        promise.set_exception(std::current_exception());
      }
    }
    return future.get();
  }

  // The device's values of block `index`, once its preparation (if any) is complete.
  // The values are allocated under the device's lock, so that one block's values are held while
  // it is computed, as before the preparation was shared; the inputs are freed as soon as the
  // device took them, also when it failed (a failed block stays in blocks_ for the run).
  Values Compute(std::int64_t index, SharedPreparation* preparation) const {
    if (preparation != nullptr && !preparation->Wait()) throw std::bad_alloc();
    auto block = std::make_shared<BlockValues>();
    const gpu_internal::PreparedTrials prepared =
        preparation != nullptr ? preparation->inputs().prepared() : gpu_internal::PreparedTrials{};
    try {
      const std::lock_guard<std::mutex> one_at_a_time(compute_mutex_);
      block->values.resize(static_cast<std::size_t>(point_outputs_) * static_cast<std::size_t>(block_));
      backend_->Compute(static_cast<std::uint64_t>(index * block_), static_cast<int>(block_), prepared,
                        block->values.data());
    } catch (...) {
      if (preparation != nullptr) preparation->Release();
      throw;
    }
    if (preparation != nullptr) block->unprepared = preparation->Release();
    return block;
  }

  // `count` more trials of block `index` copied out: forgotten when all were (the last block's
  // trials beyond M never are; it goes with the kernel).
  void CopiedOut(std::int64_t index, int count) const {
    const std::lock_guard<std::mutex> lock(mutex_);
    auto it = blocks_.find(index);
    if (it != blocks_.end() && (it->second.left -= count) <= 0) blocks_.erase(it);
  }

  void Fail(const std::string& why) const {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (failure_.empty()) failure_ = why;
    failed_.store(true);
  }

  JobKernel cpu_;
  std::unique_ptr<gpu_internal::TrialsBackend> backend_;
  int point_outputs_;
  What what_;
  bool fall_back_;
  std::int64_t block_ = kSubBatch;
  mutable std::mutex mutex_;
  mutable std::mutex compute_mutex_;
  mutable std::map<std::int64_t, Entry> blocks_;
  mutable std::atomic<bool> failed_{false};
  mutable std::string failure_;
};

// Whether the GPU kernel can draw the tracker's parameters itself, each from its own stream
// (gpu/point_trials.h PointOfTrial): each is normal or fixed, and correlated with no other input
// (the air's, pose's and thermal inputs, drawn on the CPU, may be correlated among themselves).
// Otherwise the CPU draws them — through the copula and the inverse CDFs, which call libm — and
// hands them to the kernel.
// `inputs`: the model's shared inputs (SharedDistributions).
bool DeviceDrawsTheParameters(const MeasurementModel& model, const std::vector<Distribution>& inputs) {
  const int num_params = model.setup().model->num_params;
  for (int k = 0; k < num_params; ++k) {
    const Distribution& d = inputs[static_cast<std::size_t>(k)];
    if (d.u() != 0.0 && d.kind() != DistributionKind::kNormal) return false;
  }
  // (The matrix is symmetric: a parameter's row holds every pair it is in.)
  const Eigen::MatrixXd& correlation = model.shared_correlation();
  for (Eigen::Index i = 0; i < std::min<Eigen::Index>(num_params, correlation.rows()); ++i) {
    for (Eigen::Index j = 0; j < correlation.cols(); ++j) {
      if (i != j && correlation(i, j) != 0.0) return false;
    }
  }
  return true;
}

// The GPU kernel's job for `job` (gpu/point_trials.h), or why the kernel does not cover it.
std::optional<gpu_internal::TrialsJob> KernelJob(const McmJob& job, std::uint64_t seed, std::string* why_not) {
  const MeasurementModel& model = *job.model;
  const MeasurementSetup& setup = model.setup();
  const auto refuse = [&](const std::string& why) {
    *why_not = why;
    return std::nullopt;
  };
  if (!gpu_internal::KernelHasModel(setup.model->name) || !model.has_forward_lanes()) {
    return refuse(std::string("the GPU kernel has no model '") + setup.model->name + "'");
  }
  const int num_params = setup.model->num_params;
  if (num_params > gpu_internal::kMaxParams) {
    return refuse("the GPU kernel takes at most " + std::to_string(gpu_internal::kMaxParams) + " tracker parameters");
  }
  gpu_internal::TrialsJob trials;
  trials.model = setup.model->name;
  gpu_internal::PointTrialsJob& kernel = trials.job;
  kernel.seed = seed;
  kernel.num_params = num_params;
  kernel.first_reading_stream = model.num_shared();
  kernel.air = model.environment_offset() >= 0;
  kernel.pose = model.pose_offset() >= 0;
  kernel.thermal = model.thermal_offset() >= 0;
  const std::vector<Distribution> inputs = SharedDistributions(model);
  kernel.params_drawn = !DeviceDrawsTheParameters(model, inputs);
  for (int k = 0; k < kernel.num_params; ++k) {
    const Distribution& d = inputs[static_cast<std::size_t>(k)];
    kernel.param_estimate[k] = d.estimate();
    kernel.param_u[k] = d.u();
  }
  const std::size_t most_points =
      static_cast<std::size_t>(GpuJobKernel::MostPoints(mcm_internal::CpuTrialInputs::For(kernel)));
  if (job.points.size() > most_points) {
    return refuse("the GPU kernel takes at most " + std::to_string(most_points) + " points a run");
  }
  kernel.num_points = static_cast<int>(job.points.size());
  trials.points.resize(job.points.size());
  for (std::size_t p = 0; p < job.points.size(); ++p) {
    const Eigen::Vector3d& r = job.points[p].readings;
    const Eigen::Vector3d u = model.reading_uncertainty(r(0));
    for (int j = 0; j < 3; ++j) {
      trials.points[p].reading[j] = r(j);
      trials.points[p].reading_u[j] = u(j);
    }
  }
  return trials;
}

// Whether `backend` gives the CPU engine's values for the first kCheckTrials trials of `job`, bit
// for bit: "" when it does, else what differs. Every GPU run is checked so before it is used (the
// GPU path rests on the same bits; a driver or compiler that breaks them is not used).
constexpr int kCheckTrials = 64;
std::string DiffersFromTheCpu(const McmJob& job, std::uint64_t seed, mcm_internal::CpuTrialInputs::What what,
                              gpu_internal::TrialsBackend& backend) {
  // The CPU's part first, outside the catch below: an error of the job's own inputs (an air
  // index out of its equation's range) is the job's error, not the GPU's.
  const std::vector<double> on_cpu = mcm_internal::JobTrialValues(job, seed, 0, kCheckTrials);
  const mcm_internal::CpuTrialInputs inputs = mcm_internal::JobTrialInputs(job, seed, 0, kCheckTrials, what);
  std::vector<double> on_gpu(on_cpu.size());
  try {
    backend.Compute(0, kCheckTrials, inputs.prepared(), on_gpu.data());
  } catch (const std::exception& e) {
    return std::string("the GPU failed its check against the CPU (") + e.what() + ")";
  }
  std::size_t differing = 0;
  for (std::size_t v = 0; v < on_cpu.size(); ++v) differing += std::memcmp(&on_cpu[v], &on_gpu[v], sizeof(double)) != 0;
  if (differing == 0) return "";
  return "its values differ from the CPU's in " + std::to_string(differing) + " of " + std::to_string(on_cpu.size()) +
         " (the first " + std::to_string(kCheckTrials) + " trials checked): not used";
}

// The GPU kernel of `job` for `settings.device`: nullptr for the CPU, with result.device_note
// saying why under kAuto; InputError under kGpu when no GPU can run it, or when its values are
// not the CPU's (DiffersFromTheCpu).
std::unique_ptr<GpuJobKernel> GpuKernelFor(const McmJob& job, const McmSettings& settings, McmResult& result) {
  if (settings.device == McmDevice::kCpu) return nullptr;
  std::string why_not;
  std::unique_ptr<gpu_internal::TrialsBackend> backend;
  mcm_internal::CpuTrialInputs::What what;
  if (const auto trials = KernelJob(job, settings.seed, &why_not)) {
    what = mcm_internal::CpuTrialInputs::For(trials->job);
    backend = gpu_internal::MakeBackend(*trials, &why_not);
  }
  if (backend != nullptr) {
    why_not = DiffersFromTheCpu(job, settings.seed, what, *backend);
    if (!why_not.empty()) {
      why_not = backend->Description() + ": " + why_not;
      backend.reset();
    }
  }
  if (backend == nullptr) {
    if (settings.device == McmDevice::kGpu) throw InputError(settings.device_where + ": \"gpu\": " + why_not);
    result.device_note = why_not;
    return nullptr;
  }
  return std::make_unique<GpuJobKernel>(job, std::move(backend), what, settings.trials,
                                        settings.device == McmDevice::kAuto);
}

}  // namespace

std::vector<double> mcm_internal::JobTrialValues(const McmJob& job, std::uint64_t seed, std::int64_t first,
                                                 int n) {
  const JobKernel kernel(job);
  mcm_internal::Scratch scratch;
  kernel.InitScratch(scratch);
  const mcm_internal::KeyedStream rng(seed);
  const int outputs = 3 * static_cast<int>(job.points.size());
  std::vector<double> batch(static_cast<std::size_t>(kernel.num_outputs()) * mcm_internal::kSubBatch);
  std::vector<double> values(static_cast<std::size_t>(outputs) * static_cast<std::size_t>(n));
  for (int begin = 0; begin < n; begin += mcm_internal::kSubBatch) {
    const int count = std::min(mcm_internal::kSubBatch, n - begin);
    kernel.Run(rng, first + begin, count, scratch, batch.data());
    for (int o = 0; o < outputs; ++o) {
      for (int i = 0; i < count; ++i) {
        values[static_cast<std::size_t>(o) * n + begin + i] = batch[static_cast<std::size_t>(o) * mcm_internal::kSubBatch + i];
      }
    }
  }
  return values;
}

mcm_internal::CpuTrialInputs mcm_internal::JobTrialInputs(const McmJob& job, std::uint64_t seed, std::int64_t first,
                                                          int n, CpuTrialInputs::What what) {
  const JobKernel kernel(job);
  mcm_internal::Scratch scratch;
  kernel.InitScratch(scratch);
  return InputsOfTrials(kernel, mcm_internal::KeyedStream(seed), first, n, scratch, what);
}

mcm_internal::CpuTrialInputs::What mcm_internal::CpuTrialInputs::For(const gpu_internal::PointTrialsJob& job) {
  return What{job.air != 0 || job.pose != 0 || job.thermal != 0, job.params_drawn != 0 ? job.num_params : 0};
}

gpu_internal::PreparedTrials mcm_internal::CpuTrialInputs::prepared() const {
  return gpu_internal::PreparedTrials{stages.empty() ? nullptr : stages.data(), params.empty() ? nullptr : params.data()};
}

McmResult RunMcm(const McmJob& job_in, const McmSettings& settings) {
  if (job_in.model == nullptr) throw InputError("Monte Carlo: job has no measurement model");
  if (job_in.points.empty()) throw InputError("Monte Carlo: job has no points");
  McmJob job;
  job.model = job_in.model;
  job.points = job_in.points;
  job.tasks = FitTasks(job_in);
  job.tasks.insert(job.tasks.end(), job_in.tasks.begin(), job_in.tasks.end());
  const JobKernel kernel(job);
  mcm_internal::OutputSpec spec;
  static constexpr const char* kAxes[] = {"x", "y", "z"};
  for (std::size_t p = 0; p < job.points.size(); ++p) {
    spec.groups.push_back({job.points[p].name, static_cast<int>(spec.names.size()), 3, true});
    for (const char* axis : kAxes) {
      spec.names.push_back(job.points[p].name + "." + axis);
      spec.units.push_back("m");
    }
  }
  for (const McmTask& task : job.tasks) {
    spec.names.insert(spec.names.end(), task.output_names.begin(), task.output_names.end());
    spec.units.insert(spec.units.end(), task.output_units.begin(), task.output_units.end());
  }
  McmResult where;
  const std::unique_ptr<GpuJobKernel> gpu = GpuKernelFor(job, settings, where);
  McmResult result = mcm_internal::RunEngine(gpu ? static_cast<const mcm_internal::TrialKernel&>(*gpu) : kernel, spec,
                                             settings);
  result.device = gpu ? "gpu: " + gpu->Description() : "cpu";
  result.device_note = where.device_note;
  if (gpu && !gpu->failure().empty()) {
    result.device_note = "the GPU failed during the run (" + gpu->failure() +
                         "); the trials from there on ran on the CPU (the same bits)";
  }
  return result;
}

}  // namespace vlt
