// mcm/job.cc — Monte Carlo over a laser tracker job (vlt/mcm.h RunMcm): shared inputs drawn
// once per trial (common to every point), readings per point, each point through the exact
// measurement model, then each task from the drawn points.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gpu/trials.h"
#include "mcm/engine.h"
#include "mcm/gpu_run.h"
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

class JobKernel final : public mcm_internal::MirroredKernel {
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
          if (i + kL <= n) {
            // A whole group: each row's kL trials are already side by side, read and written in
            // place (rows of kSubBatch).
            for (int l = 0; l < kL; ++l) lane_states[l] = &states[i + l];
            model_.EvaluatePreparedLanes(lane_states, readings + i, shared_soa + i, out_x + i, kSubBatch);
          } else {
            double r[3 * kL], y[3 * kL];
            LastGroupLanes(i, n, shared_soa, readings, states, lane_states, r, params_lanes);
            model_.EvaluatePreparedLanes(lane_states, r, params_lanes, y);
            for (int j = 0; j < 3; ++j) std::memcpy(out_x + j * kSubBatch + i, y + kL * j, sizeof(double) * (n - i));
          }
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
                     gpu_internal::TrialStages* stages, double* params, std::int64_t stride) const override {
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
  void RunTasks(int n, Scratch& scratch, double* outputs) const override {
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
      static_cast<std::size_t>(mcm_internal::GpuTrialKernel::MostOutputs(mcm_internal::CpuTrialInputs::For(kernel)) / 3);
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

}  // namespace

std::vector<double> mcm_internal::JobTrialValues(const McmJob& job, std::uint64_t seed, std::int64_t first,
                                                 int n) {
  return CpuTrialValues(JobKernel(job), 3 * static_cast<int>(job.points.size()), seed, first, n);
}

mcm_internal::CpuTrialInputs mcm_internal::JobTrialInputs(const McmJob& job, std::uint64_t seed, std::int64_t first,
                                                          int n, CpuTrialInputs::What what) {
  return CpuPreparedInputs(JobKernel(job), seed, first, n, what);
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
  std::unique_ptr<mcm_internal::GpuTrialKernel> gpu;
  if (settings.device != McmDevice::kCpu) {
    std::string why_not;
    const std::optional<gpu_internal::TrialsJob> trials = KernelJob(job, settings.seed, &why_not);
    gpu = mcm_internal::GpuKernelFor(kernel, trials, why_not, settings, where);
  }
  McmResult result = mcm_internal::RunEngine(gpu ? static_cast<const mcm_internal::TrialKernel&>(*gpu) : kernel, spec,
                                             settings);
  result.device_note = where.device_note;
  mcm_internal::NoteDevice(gpu.get(), result);
  return result;
}

}  // namespace vlt
