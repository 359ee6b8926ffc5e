// mcm/gpu_run.h: the engine's trials from a GPU backend, in blocks, with what the CPU prepares for
// each block shared by the engine's threads (docs/gpu.md "How it works").
#include "mcm/gpu_run.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <new>
#include <stdexcept>

#include "vlt/error.h"

namespace vlt::mcm_internal {
namespace {

std::atomic<bool> allow_computing_ahead{true};  // AllowComputingAhead

// What the GPU kernel takes from the CPU for trials first .. first + n - 1 (what.stages: a tracker
// job's stages — air, pose, thermal; what.params: the model's parameters), sized.
CpuTrialInputs SizedInputs(CpuTrialInputs::What what, int n) {
  CpuTrialInputs inputs;
  if (what.stages) inputs.stages.resize(static_cast<std::size_t>(n));
  inputs.params.resize(static_cast<std::size_t>(what.params) * static_cast<std::size_t>(n));
  return inputs;
}

// Sub-batch k (trials first + k kSubBatch .., at most kSubBatch of the n) of `inputs`, drawn and
// prepared by the CPU kernel's own code. With `unprepared`, a sub-batch whose stages fail (a drawn
// humidity past 100 %: an error of the job's own inputs) is marked there, (*unprepared)[k] = 1,
// instead of failing: a block holds trials the run may never use (past M, after an adaptive run
// stops), and where the run does use them the CPU path computes them and says what is wrong, at
// the trial it is wrong.
void PrepareSubBatch(const MirroredKernel& cpu, const KeyedStream& rng, std::int64_t first, int n, int k, Scratch& scratch,
                     CpuTrialInputs& inputs, std::vector<char>* unprepared) {
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
CpuTrialInputs InputsOfTrials(const MirroredKernel& cpu, const KeyedStream& rng, std::int64_t first, int n,
                                            Scratch& scratch, CpuTrialInputs::What what) {
  CpuTrialInputs inputs = SizedInputs(what, n);
  for (int k = 0; k < SubBatches(n); ++k) PrepareSubBatch(cpu, rng, first, n, k, scratch, inputs, nullptr);
  return inputs;
}

}  // namespace

// What the CPU prepares for one block of a GPU run (InputsOfTrials' sub-batches), shared by the
// engine's threads: each thread that needs the block prepares sub-batches until none is left, then
// waits for the block's values; the thread that computes the block hands them to the device once
// all are prepared. (Before, the computing thread prepared the whole block while the others waited,
// so one thread's rate bounded any GPU run: 6.5 M trials/s with the air on the 2-core machine of
// docs/performance.md §4.15.) The draws depend on the trial only, so which thread prepares a
// sub-batch changes no bit.
class SharedPreparation {
 public:
  SharedPreparation(CpuTrialInputs::What what, std::int64_t first, int n)
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
  void Help(const MirroredKernel& cpu, const KeyedStream& rng, Scratch& scratch) {
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

  const CpuTrialInputs& inputs() const { return inputs_; }
  // After the device took the inputs (every sub-batch prepared, so no thread writes them): the
  // sub-batches that could not be prepared; the inputs are freed.
  std::vector<char> Release() {
    inputs_ = {};
    return std::move(unprepared_);
  }

 private:
  CpuTrialInputs::What what_;
  std::int64_t first_;
  int n_;
  int sub_batches_;
  CpuTrialInputs inputs_;
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

// The buffers of blocks' values: handed back when a block is forgotten, taken by the next block
// computed. A new buffer costs its zeroing and its first touch of every page (24 MiB for a block
// of 2^20 trials of one point) under the device's lock, where no other block can start: on the
// stand-in device of bench mcm/gpu_path that was a fifth of the CPU's part of a run
// (docs/performance.md 4.16). The backend writes every value of a block (TrialsBackend::Compute),
// so a buffer is used again as it is. At most kMostSpare are kept (the blocks alive at once are
// the one copied out and the one computed next, a few more on many threads); the rest are freed.
class BlockBuffers {
 public:
  // Room for the spare buffers up front: Give runs in a block's deleter, where it must not throw.
  BlockBuffers() { spare_.reserve(kMostSpare); }

  std::vector<double> Take(std::size_t n) {
    std::vector<double> values;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (!spare_.empty()) {
        values = std::move(spare_.back());
        spare_.pop_back();
      }
    }
    if (values.capacity() < n) allocated_.fetch_add(1);
    values.resize(n);  // nothing to zero where the buffer held n values already
    return values;
  }

  void Give(std::vector<double>&& values) {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (spare_.size() < kMostSpare) spare_.push_back(std::move(values));
  }

  std::int64_t allocated() const { return allocated_.load(); }

 private:
  static constexpr std::size_t kMostSpare = 2;
  std::mutex mutex_;
  std::vector<std::vector<double>> spare_;
  std::atomic<std::int64_t> allocated_{0};  // buffers that had to grow (tests)
};

GpuTrialKernel::GpuTrialKernel(const MirroredKernel& cpu, int device_outputs,
                               std::unique_ptr<gpu_internal::TrialsBackend> backend, What what, std::int64_t trials,
                               bool fall_back)
    : cpu_(cpu), device_outputs_(device_outputs), backend_(std::move(backend)), what_(what), fall_back_(fall_back),
      trials_(trials), buffers_(std::make_shared<BlockBuffers>()) {
  // An eighth of M a block (the device busy while the engine's threads copy out the previous
  // one), at least 4096 trials, at most 2^20 and kBlockBytes of values, stages and parameters.
  const std::int64_t fit = kBlockBytes / BytesPerTrial(device_outputs_, what_);
  const std::int64_t wanted = trials > 0 ? std::max<std::int64_t>(4096, (trials + 7) / 8) : std::int64_t{1} << 20;
  block_ = std::max<std::int64_t>(kSubBatch, std::min({wanted, std::int64_t{1} << 20, fit}));
}

GpuTrialKernel::~GpuTrialKernel() = default;

namespace {

std::int64_t PreparedBytes(CpuTrialInputs::What what) {
  const std::int64_t stages = what.stages ? static_cast<std::int64_t>(sizeof(gpu_internal::TrialStages)) : 0;
  return stages + 8 * std::int64_t{what.params};
}

}  // namespace

std::int64_t GpuTrialKernel::BytesPerTrial(int device_outputs, What what) {
  return 8 * std::int64_t{std::max(1, device_outputs)} + PreparedBytes(what);
}

std::int64_t GpuTrialKernel::MostOutputs(What what) { return (kBlockBytes / kSubBatch - PreparedBytes(what)) / 8; }

void GpuTrialKernel::Run(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch, double* outputs) const {
  if (failed_.load()) return cpu_.Run(rng, first, n, scratch, outputs);
  bool from_blocks = false;
  try {
    from_blocks = CopyFromBlocks(rng, first, n, scratch, outputs);
  } catch (const std::exception& e) {
    if (!fall_back_) throw;
    Fail(e.what());
    return cpu_.Run(rng, first, n, scratch, outputs);
  } catch (...) {
    if (!fall_back_) throw;
    Fail("the device failed with an error that says nothing");
    return cpu_.Run(rng, first, n, scratch, outputs);
  }
  // Trials whose stages the CPU could not prepare, or that the device marked: the CPU path
  // computes them, or says what is wrong with the job's inputs (not the GPU's failure).
  if (!from_blocks) return cpu_.Run(rng, first, n, scratch, outputs);
  cpu_.RunTasks(n, scratch, outputs);
}

void GpuTrialKernel::TrialsRunBefore(std::int64_t end) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  for (auto it = blocks_.begin(); it != blocks_.end();) {
    const std::int64_t block_end = (it->first + 1) * block_;
    const std::int64_t last = trials_ > 0 ? std::min(block_end, trials_) : block_end;
    it = last <= end ? blocks_.erase(it) : std::next(it);
  }
}

std::size_t GpuTrialKernel::BlocksHeld() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return blocks_.size();
}

std::int64_t GpuTrialKernel::BuffersAllocated() const { return buffers_->allocated(); }

std::string GpuTrialKernel::failure() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return failure_;
}

// false: some trial's values are the CPU's to compute (their stages could not be prepared, or the
// device marked them NaN).
bool GpuTrialKernel::CopyFromBlocks(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch,
                                    double* outputs) const {
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
    for (int o = 0; prepared && o < device_outputs_; ++o) {
      const double* from =
          block->values.data() + static_cast<std::size_t>(o) * static_cast<std::size_t>(block_) + offset;
      double* to = outputs + static_cast<std::size_t>(o) * kSubBatch + done;
      std::copy(from, from + count, to);
      // NaN: the device's mark where it cannot promise the CPU's bits (base/portable_math.h
      // SinCos beyond 2^19 rad), or a value the model has none for; either way the CPU computes
      // the sub-batch, with its own values or the engine's error.
      for (int i = 0; i < count; ++i) prepared = prepared && to[i] == to[i];
    }
    CopiedOut(index, count);
    done += count;
  }
  return prepared;
}

GpuTrialKernel::Claim GpuTrialKernel::ClaimBlock(std::int64_t index, bool ahead) const {
  Claim claim;
  const std::lock_guard<std::mutex> lock(mutex_);
  const auto at = static_cast<std::size_t>(index);
  if (ahead && at < claimed_.size() && claimed_[at]) return claim;
  if (at >= claimed_.size()) claimed_.resize(at + 1, false);
  claimed_[at] = true;
  auto it = blocks_.find(index);
  if (it != blocks_.end()) {
    claim.values = it->second.values;
    claim.preparation = it->second.preparation;
    return claim;
  }
  claim.promise.emplace();
  claim.values = claim.promise->get_future().share();
  if (what_.any()) claim.preparation = std::make_shared<SharedPreparation>(what_, index * block_, static_cast<int>(block_));
  blocks_.emplace(index, Entry{claim.values, claim.preparation, block_});
  return claim;
}

void GpuTrialKernel::Serve(std::int64_t index, Claim& claim, const KeyedStream& rng, Scratch& scratch) const {
  if (claim.promise && claim.preparation) claim.preparation->Allocate();
  if (claim.preparation) claim.preparation->Help(cpu_, rng, scratch);
  if (!claim.promise) return;
  try {
    claim.promise->set_value(Compute(index, claim.preparation.get()));
  } catch (...) {
    claim.promise->set_exception(std::current_exception());
  }
}

GpuTrialKernel::Values GpuTrialKernel::Block(std::int64_t index, const KeyedStream& rng, Scratch& scratch) const {
  Claim claim = ClaimBlock(index);
  Serve(index, claim, rng, scratch);
  // Another thread computes this block: rather than wait, hand the device the next one as soon as
  // it is done with this one, so that it works while the engine's threads use this block's values
  // (the device's time overlapped with the CPU's). Only where the CPU prepares nothing for a block:
  // a thread that prepared the next block alone kept the others waiting for its own trials (a
  // one-point job with the air went from 8.2-9.1 to 6.9-7.2 M trials/s on 2 threads, §4.15).
  if (!claim.promise && !what_.any() && allow_computing_ahead.load() && claim.values.wait_for(std::chrono::seconds(0)) != std::future_status::ready) {
    Ahead(index + 1, rng, scratch);
  }
  return claim.values.get();
}

void GpuTrialKernel::Ahead(std::int64_t index, const KeyedStream& rng, Scratch& scratch) const {
  // Not past a fixed M (an adaptive run computes at most one block it does not use), nor after a
  // failure (the run goes on on the CPU).
  if (failed_.load() || (trials_ > 0 && index * block_ >= trials_)) return;
  Claim claim = ClaimBlock(index, /*ahead=*/true);
  if (claim.promise) Serve(index, claim, rng, scratch);
}

// The device's values of block `index`, once its preparation (if any) is complete.
// The values' buffer is taken under the device's lock, so that one block's values are held while
// it is computed, as before the preparation was shared; the inputs are freed as soon as the
// device took them, also when it failed (a failed block stays in blocks_ for the run).
GpuTrialKernel::Values GpuTrialKernel::Compute(std::int64_t index, SharedPreparation* preparation) const {
  if (preparation != nullptr && !preparation->Wait()) throw std::bad_alloc();
  // The block's buffer goes back to buffers_ when the last thread holding the block lets it go.
  const std::shared_ptr<BlockBuffers> buffers = buffers_;
  std::shared_ptr<BlockValues> block(new BlockValues, [buffers](BlockValues* forgotten) {
    buffers->Give(std::move(forgotten->values));
    delete forgotten;
  });
  const gpu_internal::PreparedTrials prepared =
      preparation != nullptr ? preparation->inputs().prepared() : gpu_internal::PreparedTrials{};
  try {
    const std::lock_guard<std::mutex> one_at_a_time(compute_mutex_);
    block->values =
        buffers_->Take(static_cast<std::size_t>(device_outputs_) * static_cast<std::size_t>(block_));
    backend_->Compute(static_cast<std::uint64_t>(index * block_), static_cast<int>(block_), prepared,
                      block->values.data());
  } catch (...) {
    if (preparation != nullptr) preparation->Release();
    throw;
  }
  if (preparation != nullptr) block->unprepared = preparation->Release();
  return block;
}

// `count` more trials of block `index` copied out: forgotten when all were (a fixed M's last
// block, whose trials past M never are, and under MPI every block a rank shares with another go at
// the end of the engine's wave, TrialsRunBefore).
void GpuTrialKernel::CopiedOut(std::int64_t index, int count) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  auto it = blocks_.find(index);
  if (it != blocks_.end() && (it->second.left -= count) <= 0) blocks_.erase(it);
}

void GpuTrialKernel::Fail(const std::string& why) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (failure_.empty()) failure_ = why;
  failed_.store(true);
}


std::vector<double> CpuTrialValues(const TrialKernel& kernel, int outputs, std::uint64_t seed, std::int64_t first,
                                   int n) {
  Scratch scratch;
  kernel.InitScratch(scratch);
  const KeyedStream rng(seed);
  std::vector<double> batch(static_cast<std::size_t>(kernel.num_outputs()) * kSubBatch);
  std::vector<double> values(static_cast<std::size_t>(outputs) * static_cast<std::size_t>(n));
  for (int begin = 0; begin < n; begin += kSubBatch) {
    const int count = std::min(kSubBatch, n - begin);
    kernel.Run(rng, first + begin, count, scratch, batch.data());
    for (int o = 0; o < outputs; ++o) {
      for (int i = 0; i < count; ++i) {
        values[static_cast<std::size_t>(o) * n + begin + i] = batch[static_cast<std::size_t>(o) * kSubBatch + i];
      }
    }
  }
  return values;
}

CpuTrialInputs CpuPreparedInputs(const MirroredKernel& kernel, std::uint64_t seed, std::int64_t first, int n,
                                 CpuTrialInputs::What what) {
  Scratch scratch;
  kernel.InitScratch(scratch);
  return InputsOfTrials(kernel, KeyedStream(seed), first, n, scratch, what);
}

CpuTrialInputs::What CpuTrialInputs::For(const gpu_internal::PointTrialsJob& job) {
  return What{job.air != 0 || job.pose != 0 || job.thermal != 0, job.params_drawn != 0 ? job.num_params : 0};
}

gpu_internal::PreparedTrials CpuTrialInputs::prepared() const {
  return gpu_internal::PreparedTrials{stages.empty() ? nullptr : stages.data(), params.empty() ? nullptr : params.data()};
}

namespace {

// Whether `backend` gives the CPU engine's device outputs of the first kCheckTrials trials, bit
// for bit: "" when it does, else what differs. Every GPU run is checked so before it is used (the
// GPU path rests on the same bits; a driver or compiler that breaks them is not used).
constexpr int kCheckTrials = 64;
std::string DiffersFromTheCpu(const MirroredKernel& cpu, int device_outputs, std::uint64_t seed,
                              CpuTrialInputs::What what, gpu_internal::TrialsBackend& backend) {
  // The CPU's part first, outside the catch below: an error of the job's own inputs (an air
  // index out of its equation's range) is the job's error, not the GPU's.
  const std::vector<double> on_cpu = CpuTrialValues(cpu, device_outputs, seed, 0, kCheckTrials);
  const CpuTrialInputs inputs = CpuPreparedInputs(cpu, seed, 0, kCheckTrials, what);
  std::vector<double> on_gpu(on_cpu.size());
  try {
    backend.Compute(0, kCheckTrials, inputs.prepared(), on_gpu.data());
  } catch (const std::exception& e) {
    return std::string("the GPU failed its check against the CPU (") + e.what() + ")";
  }
  // A NaN from the device is the CPU's to compute (GpuTrialKernel::CopyFromBlocks), whatever its bits.
  std::size_t differing = 0;
  for (std::size_t v = 0; v < on_cpu.size(); ++v) {
    differing += on_gpu[v] == on_gpu[v] && std::memcmp(&on_cpu[v], &on_gpu[v], sizeof(double)) != 0;
  }
  if (differing == 0) return "";
  return "its values differ from the CPU's in " + std::to_string(differing) + " of " + std::to_string(on_cpu.size()) +
         " (the first " + std::to_string(kCheckTrials) + " trials checked): not used";
}

}  // namespace

std::unique_ptr<GpuTrialKernel> GpuKernelFor(const MirroredKernel& cpu, const std::optional<gpu_internal::TrialsJob>& trials,
                                             std::string why_not, const McmSettings& settings, McmResult& result) {
  if (settings.device == McmDevice::kCpu) return nullptr;
  std::unique_ptr<gpu_internal::TrialsBackend> backend;
  CpuTrialInputs::What what;
  int device_outputs = 0;
  if (trials) {
    what = CpuTrialInputs::For(trials->job);
    device_outputs = trials->job.outputs_per_point * trials->job.num_points;
    backend = gpu_internal::MakeBackend(*trials, &why_not);
  }
  if (backend != nullptr) {
    why_not = DiffersFromTheCpu(cpu, device_outputs, settings.seed, what, *backend);
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
  return std::make_unique<GpuTrialKernel>(cpu, device_outputs, std::move(backend), what, settings.trials,
                                          settings.device == McmDevice::kAuto);
}

void AllowComputingAhead(bool allow) { allow_computing_ahead.store(allow); }

void NoteDevice(const GpuTrialKernel* gpu, McmResult& result) {
  result.device = gpu != nullptr ? "gpu: " + gpu->Description() : "cpu";
  if (gpu != nullptr && !gpu->failure().empty()) {
    result.device_note = "the GPU failed during the run (" + gpu->failure() +
                         "); the trials from there on ran on the CPU (the same bits)";
  }
}

}  // namespace vlt::mcm_internal
