// mcm/gpu_run.h — the Monte Carlo engine's trials computed by a GPU (docs/gpu.md): a trial kernel
// of the engine (mcm/engine.h) that takes the values of a MirroredKernel's trials from a backend
// (gpu/trials.h) in blocks, and computes on the CPU what the device does not (a job's tasks). The
// tracker job (mcm/job.cc) and the custom model (mcm/custom.cc) build their kernel's job for the
// device and ask GpuKernelFor for this kernel.
#pragma once

#include <atomic>
#include <cstdint>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "gpu/trials.h"
#include "mcm/engine.h"
#include "vlt/mcm.h"

namespace vlt::mcm_internal {

class SharedPreparation;
struct BlockValues;
class BlockBuffers;

// A MirroredKernel's trials on a GPU: its device outputs (the first device_outputs of each trial)
// from the backend — the same draws and model as the CPU kernel's Run, the same bits —, the rest
// (RunTasks) on the CPU by the kernel's own code. The device computes blocks of trials, one block
// at a time; the engine's threads ask for sub-batches (at most kSubBatch trials, anywhere in a
// block) and copy theirs out of the block that holds them. A block is computed by the first thread
// that needs it and forgotten once all its trials were copied out.
class GpuTrialKernel final : public TrialKernel {
 public:
  // Most bytes of values and of what the CPU prepares a block holds (kSubBatch trials at least:
  // the kernel's jobs refuse more outputs).
  static constexpr std::int64_t kBlockBytes = std::int64_t{64} << 20;
  using What = CpuTrialInputs::What;

  // cpu: the kernel mirrored (outlives this one). device_outputs: the outputs the backend computes
  // per trial. what: the stages and parameters the CPU prepares for the device. trials: the run's M
  // (0: adaptive). fall_back: on a GPU failure during the run, compute the remaining trials on the
  // CPU (the same bits; McmDevice::kAuto) instead of failing.
  GpuTrialKernel(const MirroredKernel& cpu, int device_outputs, std::unique_ptr<gpu_internal::TrialsBackend> backend,
                 What what, std::int64_t trials, bool fall_back);
  ~GpuTrialKernel() override;

  // A trial's values in a block, and what the CPU prepares for it.
  static std::int64_t BytesPerTrial(int device_outputs, What what);
  // The most device outputs a trial may have so that kSubBatch trials (the least a block holds) fit
  // in kBlockBytes.
  static std::int64_t MostOutputs(What what);

  int num_outputs() const override { return cpu_.num_outputs(); }
  void InitScratch(Scratch& scratch) const override { cpu_.InitScratch(scratch); }
  std::vector<double> AtEstimates() const override { return cpu_.AtEstimates(); }
  void Run(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch, double* outputs) const override;
  // Forgets the blocks whose trials (up to M) all lie before `end`: under MPI a rank copies out
  // only its share of a block's trials, and a fixed M's last block holds trials past M, so that
  // counting the trials copied out does not free them.
  void TrialsRunBefore(std::int64_t end) const override;
  // Blocks held, and buffers of blocks' values allocated so far (tests: a forgotten block's buffer
  // is used again by the next).
  std::size_t BlocksHeld() const;
  std::int64_t BuffersAllocated() const;

  std::string Description() const { return backend_->Description(); }
  // Why the trials after the GPU failed ran on the CPU; "" when it did not fail.
  std::string failure() const;

 private:
  using Values = std::shared_ptr<const BlockValues>;
  struct Entry {
    std::shared_future<Values> values;
    std::shared_ptr<SharedPreparation> preparation;  // nullptr where the CPU prepares nothing
    std::int64_t left = 0;                           // trials not yet copied out
  };

  // A block's entry as a thread finds it: the promise of its values where this thread created the
  // entry (and so computes the block).
  struct Claim {
    std::shared_future<Values> values;
    std::shared_ptr<SharedPreparation> preparation;
    std::optional<std::promise<Values>> promise;
  };

  // Copies trials first .. first + n - 1 out of their blocks; false when some of them are the
  // CPU's to compute: stages the CPU could not prepare, or a value the device marked NaN (their
  // blocks' trials are counted as copied out all the same).
  bool CopyFromBlocks(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch, double* outputs) const;
  // Block `index`'s values (values[o * block_ + i]), computed once, one block at a time on the
  // device; what the CPU prepares for it shared by every thread that needs the block
  // (SharedPreparation, each in its own scratch) before the thread that computes it hands it over.
  Values Block(std::int64_t index, const KeyedStream& rng, Scratch& scratch) const;
  // Block `index`'s entry, created (with the promise) where there is none. `ahead`: only a block
  // no thread has claimed yet (one whose trials were all copied out has no entry any more, and
  // computing it again would cost the device a block); the claim is empty otherwise.
  Claim ClaimBlock(std::int64_t index, bool ahead = false) const;
  // Helps prepare the claimed block and, where this thread created it, computes it.
  void Serve(std::int64_t index, Claim& claim, const KeyedStream& rng, Scratch& scratch) const;
  // Block `index` claimed and served ahead of need, by a thread that would otherwise wait.
  void Ahead(std::int64_t index, const KeyedStream& rng, Scratch& scratch) const;
  Values Compute(std::int64_t index, SharedPreparation* preparation) const;
  void CopiedOut(std::int64_t index, int count) const;
  void Fail(const std::string& why) const;

  const MirroredKernel& cpu_;
  int device_outputs_;
  std::unique_ptr<gpu_internal::TrialsBackend> backend_;
  What what_;
  bool fall_back_;
  std::int64_t trials_;  // the run's M; 0: adaptive
  std::int64_t block_ = kSubBatch;
  mutable std::mutex mutex_;
  mutable std::mutex compute_mutex_;
  mutable std::map<std::int64_t, Entry> blocks_;
  mutable std::vector<bool> claimed_;      // claimed_[index]: block `index` was ever claimed
  std::shared_ptr<BlockBuffers> buffers_;  // shared with the blocks, which give theirs back
  mutable std::atomic<bool> failed_{false};
  mutable std::string failure_;
};

// The device outputs (the first `outputs` of each trial) of trials first .. first + n - 1 as the
// CPU engine computes them with `kernel` under `seed`, sub-batch by sub-batch: values[o * n + i].
std::vector<double> CpuTrialValues(const TrialKernel& kernel, int outputs, std::uint64_t seed, std::int64_t first,
                                   int n);
// What `kernel` prepares for the GPU kernel's trials first .. first + n - 1 (`what` of it), on
// this thread.
CpuTrialInputs CpuPreparedInputs(const MirroredKernel& kernel, std::uint64_t seed, std::int64_t first, int n,
                                 CpuTrialInputs::What what);

// The GPU's trial kernel for `cpu` under `settings.device`, `trials` its job for the device
// (nullopt: the kernel does not cover it, why_not says why). nullptr for the CPU, with
// result.device_note saying why under kAuto; InputError under kGpu when no GPU can run it, or when
// the device's values of the first trials are not the CPU's, bit for bit (checked on every run: a
// driver or compiler that breaks the bits is not used).
std::unique_ptr<GpuTrialKernel> GpuKernelFor(const MirroredKernel& cpu, const std::optional<gpu_internal::TrialsJob>& trials,
                                             std::string why_not, const McmSettings& settings, McmResult& result);

// Whether a thread that would wait for a block another computes hands the device the next block
// instead (GpuTrialKernel::Ahead; the default). Benchmarks turn it off to measure what it gains.
void AllowComputingAhead(bool allow);

// result.device and device_note after a run on `gpu` (nullptr: the CPU; the note GpuKernelFor
// left is kept).
void NoteDevice(const GpuTrialKernel* gpu, McmResult& result);

}  // namespace vlt::mcm_internal
