// The GPU backend (gpu/trials.h CudaBackend, docs/gpu.md): nothing CUDA at build time. The CUDA
// driver (libcuda.so.1) and NVRTC (libnvrtc.so) are loaded when a Monte Carlo first asks for a GPU,
// with the few entry points declared here; the kernel source — base/portable_math.h,
// gpu/point_trials.h and the model's generated header, compiled into vlt as text — is compiled by
// NVRTC for the device found, without FMA contraction (--fmad=false), so that every trial has the
// bits of the CPU engine's (tests/test_gpu_kernel.cc compiles the same text as C++).
#include <dlfcn.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <mutex>
#include <string>
#include <vector>

#include "gpu/kernel_source.h"
#include "gpu/trials.h"

namespace vlt::gpu_internal {
namespace {

// The CUDA driver API's types and entry points vlt uses (cuda.h, CUDA 11 and later: the _v2
// names are those of 64-bit device pointers).
using CUresult = int;
using CUdevice = int;
using CUcontext = struct CUctx_st*;
using CUmodule = struct CUmod_st*;
using CUfunction = struct CUfunc_st*;
using CUdeviceptr = unsigned long long;
constexpr int kComputeMajor = 75, kComputeMinor = 76;  // CU_DEVICE_ATTRIBUTE_COMPUTE_CAPABILITY_*

struct Driver {
  void* library = nullptr;
  CUresult (*cuInit)(unsigned) = nullptr;
  CUresult (*cuDriverGetVersion)(int*) = nullptr;
  CUresult (*cuDeviceGetCount)(int*) = nullptr;
  CUresult (*cuDeviceGet)(CUdevice*, int) = nullptr;
  CUresult (*cuDeviceGetName)(char*, int, CUdevice) = nullptr;
  CUresult (*cuDeviceGetAttribute)(int*, int, CUdevice) = nullptr;
  CUresult (*cuDevicePrimaryCtxRetain)(CUcontext*, CUdevice) = nullptr;
  CUresult (*cuCtxSetCurrent)(CUcontext) = nullptr;
  CUresult (*cuModuleLoadData)(CUmodule*, const void*) = nullptr;
  CUresult (*cuModuleGetFunction)(CUfunction*, CUmodule, const char*) = nullptr;
  CUresult (*cuMemAlloc)(CUdeviceptr*, std::size_t) = nullptr;
  CUresult (*cuMemFree)(CUdeviceptr) = nullptr;
  CUresult (*cuMemcpyHtoD)(CUdeviceptr, const void*, std::size_t) = nullptr;
  CUresult (*cuMemcpyDtoH)(void*, CUdeviceptr, std::size_t) = nullptr;
  CUresult (*cuLaunchKernel)(CUfunction, unsigned, unsigned, unsigned, unsigned, unsigned, unsigned, unsigned,
                             void*, void**, void**) = nullptr;
  CUresult (*cuCtxSynchronize)() = nullptr;
  CUresult (*cuGetErrorString)(CUresult, const char**) = nullptr;
};

// NVRTC's (nvrtc.h).
using nvrtcResult = int;
using nvrtcProgram = struct _nvrtcProgram*;
struct Nvrtc {
  void* library = nullptr;
  nvrtcResult (*nvrtcVersion)(int*, int*) = nullptr;
  const char* (*nvrtcGetErrorString)(nvrtcResult) = nullptr;
  nvrtcResult (*nvrtcCreateProgram)(nvrtcProgram*, const char*, const char*, int, const char* const*,
                                    const char* const*) = nullptr;
  nvrtcResult (*nvrtcCompileProgram)(nvrtcProgram, int, const char* const*) = nullptr;
  nvrtcResult (*nvrtcGetProgramLogSize)(nvrtcProgram, std::size_t*) = nullptr;
  nvrtcResult (*nvrtcGetProgramLog)(nvrtcProgram, char*) = nullptr;
  nvrtcResult (*nvrtcGetPTXSize)(nvrtcProgram, std::size_t*) = nullptr;
  nvrtcResult (*nvrtcGetPTX)(nvrtcProgram, char*) = nullptr;
  nvrtcResult (*nvrtcDestroyProgram)(nvrtcProgram*) = nullptr;
};

template <class Fn>
bool Bind(void* library, const char* name, Fn*& fn) {
  fn = reinterpret_cast<Fn*>(dlsym(library, name));
  return fn != nullptr;
}

// The first of `names` that opens, or nullptr with dlerror()'s text of the first in *error.
void* OpenFirst(std::initializer_list<const char*> names, std::string* error) {
  std::string first_error;
  for (const char* name : names) {
    if (void* library = dlopen(name, RTLD_NOW | RTLD_LOCAL)) return library;
    if (first_error.empty()) {
      const char* e = dlerror();
      first_error = e != nullptr ? e : name;
    }
  }
  *error = first_error;
  return nullptr;
}

// The driver and NVRTC, loaded once per process; why not, where they do not load or bind.
struct Loaded {
  Driver cu;
  Nvrtc rtc;
  std::string why_not;
};

bool BindDriver(Driver& d) {
  return Bind(d.library, "cuInit", d.cuInit) && Bind(d.library, "cuDriverGetVersion", d.cuDriverGetVersion) &&
         Bind(d.library, "cuDeviceGetCount", d.cuDeviceGetCount) && Bind(d.library, "cuDeviceGet", d.cuDeviceGet) &&
         Bind(d.library, "cuDeviceGetName", d.cuDeviceGetName) &&
         Bind(d.library, "cuDeviceGetAttribute", d.cuDeviceGetAttribute) &&
         Bind(d.library, "cuDevicePrimaryCtxRetain", d.cuDevicePrimaryCtxRetain) &&
         Bind(d.library, "cuCtxSetCurrent", d.cuCtxSetCurrent) && Bind(d.library, "cuModuleLoadData", d.cuModuleLoadData) &&
         Bind(d.library, "cuModuleGetFunction", d.cuModuleGetFunction) && Bind(d.library, "cuMemAlloc_v2", d.cuMemAlloc) &&
         Bind(d.library, "cuMemFree_v2", d.cuMemFree) && Bind(d.library, "cuMemcpyHtoD_v2", d.cuMemcpyHtoD) &&
         Bind(d.library, "cuMemcpyDtoH_v2", d.cuMemcpyDtoH) && Bind(d.library, "cuLaunchKernel", d.cuLaunchKernel) &&
         Bind(d.library, "cuCtxSynchronize", d.cuCtxSynchronize) && Bind(d.library, "cuGetErrorString", d.cuGetErrorString);
}

bool BindNvrtc(Nvrtc& n) {
  return Bind(n.library, "nvrtcVersion", n.nvrtcVersion) && Bind(n.library, "nvrtcGetErrorString", n.nvrtcGetErrorString) &&
         Bind(n.library, "nvrtcCreateProgram", n.nvrtcCreateProgram) &&
         Bind(n.library, "nvrtcCompileProgram", n.nvrtcCompileProgram) &&
         Bind(n.library, "nvrtcGetProgramLogSize", n.nvrtcGetProgramLogSize) &&
         Bind(n.library, "nvrtcGetProgramLog", n.nvrtcGetProgramLog) && Bind(n.library, "nvrtcGetPTXSize", n.nvrtcGetPTXSize) &&
         Bind(n.library, "nvrtcGetPTX", n.nvrtcGetPTX) && Bind(n.library, "nvrtcDestroyProgram", n.nvrtcDestroyProgram);
}

const Loaded& Load() {
  static const Loaded loaded = [] {
    Loaded l;
    std::string error;
    l.cu.library = OpenFirst({"libcuda.so.1", "libcuda.so"}, &error);
    if (l.cu.library == nullptr) {
      l.why_not = "no NVIDIA driver (" + error + ")";
      return l;
    }
    if (!BindDriver(l.cu)) {
      l.why_not = "the NVIDIA driver lacks an entry point vlt uses";
      return l;
    }
    // The NVRTC of the driver's CUDA major version first: a newer one writes PTX the driver
    // cannot load.
    int version = 0;
    l.cu.cuDriverGetVersion(&version);
    const std::string matching = "libnvrtc.so." + std::to_string(version / 1000);
    l.rtc.library =
        OpenFirst({matching.c_str(), "libnvrtc.so", "libnvrtc.so.13", "libnvrtc.so.12", "libnvrtc.so.11.2"}, &error);
    if (l.rtc.library == nullptr) {
      l.why_not = "no NVRTC, the CUDA runtime compiler (" + error + ")";
      return l;
    }
    if (!BindNvrtc(l.rtc)) l.why_not = "NVRTC lacks an entry point vlt uses";
    return l;
  }();
  return loaded;
}

std::string DriverError(const Driver& cu, const char* call, CUresult r) {
  const char* text = nullptr;
  if (cu.cuGetErrorString(r, &text) != 0 || text == nullptr) text = "unknown error";
  return std::string(call) + ": " + text + " (CUDA error " + std::to_string(r) + ")";
}

// The first device, its context current on this thread; false with *why_not.
bool OpenDevice(const Driver& cu, CUdevice* device, CUcontext* context, std::string* why_not) {
  int count = 0;
  CUresult r = cu.cuInit(0);
  if (r == 0) r = cu.cuDeviceGetCount(&count);
  if (r != 0) {
    *why_not = DriverError(cu, "cuInit", r);
    return false;
  }
  if (count < 1) {
    *why_not = "the NVIDIA driver sees no GPU";
    return false;
  }
  if ((r = cu.cuDeviceGet(device, 0)) != 0 || (r = cu.cuDevicePrimaryCtxRetain(context, *device)) != 0 ||
      (r = cu.cuCtxSetCurrent(*context)) != 0) {
    *why_not = DriverError(cu, "opening the GPU", r);
    return false;
  }
  return true;
}

// PTX of the kernel source for compute capability major.minor; empty with *error (NVRTC's log).
std::string CompileKernel(const Nvrtc& rtc, const KernelSource& source, int major, int minor, std::string* error) {
  std::vector<const char*> headers, names;
  for (const auto& [name, text] : source.headers) {
    names.push_back(name.c_str());
    headers.push_back(text.c_str());
  }
  nvrtcProgram program = nullptr;
  nvrtcResult r = rtc.nvrtcCreateProgram(&program, source.main.c_str(), "vlt_point_trials.cu",
                                         static_cast<int>(headers.size()), headers.data(), names.data());
  if (r != 0) {
    *error = std::string("NVRTC: ") + rtc.nvrtcGetErrorString(r);
    return "";
  }
  // No FMA contraction and IEEE division and square root: the CPU engine's operations, rounded
  // alike (docs/gpu.md "Why the bits match"); unannotated functions (the generated model) are
  // device functions.
  const std::string arch = "--gpu-architecture=compute_" + std::to_string(10 * major + minor);
  const char* options[] = {arch.c_str(), "--std=c++17", "--fmad=false", "--prec-div=true", "--prec-sqrt=true",
                           "--ftz=false", "--device-as-default-execution-space"};
  r = rtc.nvrtcCompileProgram(program, static_cast<int>(std::size(options)), options);
  std::size_t log_size = 0;
  rtc.nvrtcGetProgramLogSize(program, &log_size);
  std::string log(log_size, '\0');
  if (log_size > 0) rtc.nvrtcGetProgramLog(program, log.data());
  std::string ptx;
  if (r == 0) {
    std::size_t size = 0;
    rtc.nvrtcGetPTXSize(program, &size);
    ptx.assign(size, '\0');
    rtc.nvrtcGetPTX(program, ptx.data());
  } else {
    // One line: the log's lines joined, its NUL dropped, at most 400 characters.
    std::string line;
    for (char c : log) {
      if (c == '\0') continue;
      if (c == '\n') {
        if (!line.empty() && line.back() != ' ') line += "; ";
        continue;
      }
      line += c;
    }
    if (line.size() > 400) line = line.substr(0, 400) + " ...";
    *error = std::string("NVRTC could not compile the kernel: ") + rtc.nvrtcGetErrorString(r) + ": " + line;
  }
  rtc.nvrtcDestroyProgram(&program);
  return ptx;
}

class Cuda final : public TrialsBackend {
 public:
  // job, points: the job and its points on the device (freed with the backend); num_params: the
  // model's parameters of each trial where the CPU draws them; outputs: a point's.
  Cuda(const Driver& cu, CUcontext context, CUfunction kernel, CUdeviceptr job, CUdeviceptr points, int num_points,
       int num_params, int outputs, std::string description)
      : cu_(cu), context_(context), kernel_(kernel), job_(job), points_(points), num_points_(num_points),
        outputs_(outputs), description_(std::move(description)), num_params_(num_params) {}
  ~Cuda() override {
    cu_.cuCtxSetCurrent(context_);
    if (values_ != 0) cu_.cuMemFree(values_);
    if (stages_ != 0) cu_.cuMemFree(stages_);
    if (params_ != 0) cu_.cuMemFree(params_);
    cu_.cuMemFree(points_);
    cu_.cuMemFree(job_);
  }

  void Compute(std::uint64_t first, int n, const PreparedTrials& prepared, double* values) override {
    // One launch per block of trials, from whichever engine thread asks: one at a time.
    const std::lock_guard<std::mutex> lock(mutex_);
    Check("cuCtxSetCurrent", cu_.cuCtxSetCurrent(context_));
    const std::size_t bytes =
        static_cast<std::size_t>(outputs_) * static_cast<std::size_t>(num_points_) * static_cast<std::size_t>(n) * sizeof(double);
    Reserve(values_, values_capacity_, bytes);
    CUdeviceptr stages_arg = 0;
    if (prepared.stages != nullptr) {
      const std::size_t stage_bytes = static_cast<std::size_t>(n) * sizeof(TrialStages);
      Reserve(stages_, stages_capacity_, stage_bytes);
      Check("cuMemcpyHtoD", cu_.cuMemcpyHtoD(stages_, prepared.stages, stage_bytes));
      stages_arg = stages_;
    }
    CUdeviceptr params_arg = 0;
    if (prepared.params != nullptr) {
      const std::size_t param_bytes = static_cast<std::size_t>(num_params_) * static_cast<std::size_t>(n) * sizeof(double);
      Reserve(params_, params_capacity_, param_bytes);
      Check("cuMemcpyHtoD", cu_.cuMemcpyHtoD(params_, prepared.params, param_bytes));
      params_arg = params_;
    }
    unsigned long long first_trial = first;
    int count = n;
    void* params[] = {&job_, &points_, &stages_arg, &params_arg, &first_trial, &count, &values_};
    // One thread per (trial, point).
    constexpr unsigned kThreads = 128;
    const unsigned long long threads = static_cast<unsigned long long>(n) * static_cast<unsigned long long>(num_points_);
    const unsigned blocks = static_cast<unsigned>((threads + kThreads - 1) / kThreads);
    Check("cuLaunchKernel", cu_.cuLaunchKernel(kernel_, blocks, 1, 1, kThreads, 1, 1, 0, nullptr, params, nullptr));
    Check("cuCtxSynchronize", cu_.cuCtxSynchronize());
    Check("cuMemcpyDtoH", cu_.cuMemcpyDtoH(values, values_, bytes));
  }

  std::string Description() const override { return description_; }

 private:
  void Check(const char* call, CUresult r) const {
    if (r != 0) throw std::runtime_error("GPU: " + DriverError(cu_, call, r));
  }

  // A device buffer of at least `bytes` (grown, never shrunk, while the backend lives).
  void Reserve(CUdeviceptr& buffer, std::size_t& capacity, std::size_t bytes) const {
    if (bytes <= capacity) return;
    if (buffer != 0) cu_.cuMemFree(buffer);
    buffer = 0;
    capacity = 0;
    Check("cuMemAlloc", cu_.cuMemAlloc(&buffer, bytes));
    capacity = bytes;
  }

  const Driver& cu_;
  CUcontext context_;
  CUfunction kernel_;
  CUdeviceptr job_;
  CUdeviceptr points_;
  int num_points_;
  int outputs_;
  std::string description_;
  std::mutex mutex_;
  CUdeviceptr values_ = 0;
  std::size_t values_capacity_ = 0;
  CUdeviceptr stages_ = 0;  // the block's trials' stages, where the job has any
  std::size_t stages_capacity_ = 0;
  int num_params_;
  CUdeviceptr params_ = 0;  // the block's trials' parameters, where the CPU drew them
  std::size_t params_capacity_ = 0;
};

}  // namespace

std::unique_ptr<TrialsBackend> CudaBackend(const TrialsJob& trials, std::string* why_not) {
  const Loaded& loaded = Load();
  if (!loaded.why_not.empty()) {
    *why_not = loaded.why_not;
    return nullptr;
  }
  const Driver& cu = loaded.cu;
  // The device's primary context retained once per process, its kernels compiled once per model
  // and kept loaded: a job and its Monte Carlo map open and compile once.
  static std::mutex open_mutex;
  static CUdevice device = 0;
  static CUcontext context = nullptr;
  static std::map<std::string, CUfunction> kernels;
  const std::lock_guard<std::mutex> lock(open_mutex);
  if (context == nullptr) {
    if (!OpenDevice(cu, &device, &context, why_not)) {
      context = nullptr;
      return nullptr;
    }
  } else if (const CUresult r = cu.cuCtxSetCurrent(context); r != 0) {
    *why_not = DriverError(cu, "cuCtxSetCurrent", r);
    return nullptr;
  }
  int major = 0, minor = 0, driver = 0, rtc_major = 0, rtc_minor = 0;
  cu.cuDeviceGetAttribute(&major, kComputeMajor, device);
  cu.cuDeviceGetAttribute(&minor, kComputeMinor, device);
  cu.cuDriverGetVersion(&driver);
  loaded.rtc.nvrtcVersion(&rtc_major, &rtc_minor);
  CUresult r = 0;
  // Keyed by the model and, for a model built at run time, its source (a rebuilt model is another).
  CUfunction& kernel = kernels[trials.model + '\n' + trials.model_source];
  if (kernel == nullptr) {
    const std::string ptx =
        CompileKernel(loaded.rtc, PointTrialsSource(trials.model, trials.model_source), major, minor, why_not);
    if (ptx.empty()) return nullptr;
    CUmodule module = nullptr;
    r = cu.cuModuleLoadData(&module, ptx.c_str());
    if (r == 0) r = cu.cuModuleGetFunction(&kernel, module, "vlt_point_trials");
    if (r != 0) {
      kernel = nullptr;
      *why_not = DriverError(cu, "loading the kernel", r);
      return nullptr;
    }
  }
  CUdeviceptr job_on_device = 0, points_on_device = 0;
  const std::size_t points_bytes = std::max<std::size_t>(1, trials.points.size()) * sizeof(TrialPoint);
  if (r == 0) r = cu.cuMemAlloc(&job_on_device, sizeof trials.job);
  if (r == 0) r = cu.cuMemcpyHtoD(job_on_device, &trials.job, sizeof trials.job);
  if (r == 0) r = cu.cuMemAlloc(&points_on_device, points_bytes);
  if (r == 0 && !trials.points.empty()) {
    r = cu.cuMemcpyHtoD(points_on_device, trials.points.data(), trials.points.size() * sizeof(TrialPoint));
  }
  if (r != 0) {
    if (points_on_device != 0) cu.cuMemFree(points_on_device);
    if (job_on_device != 0) cu.cuMemFree(job_on_device);
    *why_not = DriverError(cu, "copying the job to the GPU", r);
    return nullptr;
  }
  char name[256] = {};
  cu.cuDeviceGetName(name, static_cast<int>(sizeof name) - 1, device);
  char description[512];
  std::snprintf(description, sizeof description, "%s (compute %d.%d; CUDA driver %d.%d, NVRTC %d.%d)", name, major,
                minor, driver / 1000, (driver % 1000) / 10, rtc_major, rtc_minor);
  return std::make_unique<Cuda>(cu, context, kernel, job_on_device, points_on_device, trials.job.num_points,
                                trials.job.num_params, trials.job.outputs_per_point, description);
}

}  // namespace vlt::gpu_internal
