// gpu_probe — what a lent GPU machine offers vlt's Monte Carlo (issue 37), with nothing CUDA at
// build time: the driver (libcuda.so.1) and NVRTC (libnvrtc.so*) are opened at run time with dlopen
// and the few entry points declared here; a kernel's C++ source is compiled by NVRTC for the
// device's own architecture (a cubin: no PTX JIT by the driver) without FMA contraction
// (--fmad=false), run, and its doubles compared bit for bit with the same function compiled for
// the CPU (-ffp-contract=off, as vlt is built).
//
// Build (no CUDA headers needed): g++ -O2 -std=c++20 -ffp-contract=off gpu_probe.cc -ldl -o gpu_probe
// Prints one line per step; exit 0 when the bits match, 1 when they differ, 2 when a library or
// device is missing.
#include <dlfcn.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

// The probe's arithmetic, written once: the kernel's body is this text (stringized) and the CPU
// function expands it, so the two are the same C++. Philox's 32 x 32 -> 64 multiply-and-mix
// rounds, a uniform from the result, then +, *, / and sqrt in double.
#define VLT_PROBE_CODE                                                       \
  unsigned int a = (unsigned int)i, b = (unsigned int)(i >> 32) ^ 0x9E3779B9u; \
  unsigned int key = 0xBB67AE85u;                                             \
  for (int r = 0; r < 10; ++r) {                                              \
    const unsigned long long p = (unsigned long long)a * 0xD2511F53u;         \
    a = (unsigned int)(p >> 32) ^ b ^ key;                                    \
    b = (unsigned int)p;                                                      \
    key += 0x9E3779B9u;                                                       \
  }                                                                           \
  const unsigned long long bits = ((unsigned long long)a << 21) ^ b;          \
  const double u = (double)(bits & 0x1FFFFFFFFFFFFFull) * 0x1p-53 + 0x1p-54; \
  const double y = u * 3.0 - 1.5;                                             \
  out[i] = (y * y + 0.25) / (1.0 + u) + sqrt(u) * y - 1e-3 * y * y * y;
#define VLT_STRINGIZE2(...) #__VA_ARGS__
#define VLT_STRINGIZE(...) VLT_STRINGIZE2(__VA_ARGS__)

const char* const kKernel =
    "extern \"C\" __global__ void probe(double* out, unsigned long long n) {\n"
    "  unsigned long long i = blockIdx.x * (unsigned long long)blockDim.x + threadIdx.x;\n"
    "  if (i >= n) return;\n" VLT_STRINGIZE(VLT_PROBE_CODE) "\n}\n";

void ProbeCpu(double* out, unsigned long long n) {
  using std::sqrt;
  for (unsigned long long i = 0; i < n; ++i) {
    VLT_PROBE_CODE
  }
}

// The driver API (cuda.h) and NVRTC (nvrtc.h) entry points used, declared by hand.
using CUresult = int;
using CUdevice = int;
using CUdeviceptr = unsigned long long;
using Opaque = void*;
struct Driver {
  CUresult (*cuInit)(unsigned);
  CUresult (*cuDriverGetVersion)(int*);
  CUresult (*cuDeviceGet)(CUdevice*, int);
  CUresult (*cuDeviceGetName)(char*, int, CUdevice);
  CUresult (*cuDeviceGetAttribute)(int*, int, CUdevice);
  CUresult (*cuDevicePrimaryCtxRetain)(Opaque*, CUdevice);
  CUresult (*cuCtxSetCurrent)(Opaque);
  CUresult (*cuModuleLoadData)(Opaque*, const void*);
  CUresult (*cuModuleGetFunction)(Opaque*, Opaque, const char*);
  CUresult (*cuMemAlloc)(CUdeviceptr*, size_t);
  CUresult (*cuMemcpyDtoH)(void*, CUdeviceptr, size_t);
  CUresult (*cuLaunchKernel)(Opaque, unsigned, unsigned, unsigned, unsigned, unsigned, unsigned, unsigned, Opaque,
                             void**, void**);
  CUresult (*cuCtxSynchronize)();
};
struct Nvrtc {
  int (*nvrtcVersion)(int*, int*);
  int (*nvrtcCreateProgram)(Opaque*, const char*, const char*, int, const char* const*, const char* const*);
  int (*nvrtcCompileProgram)(Opaque, int, const char* const*);
  int (*nvrtcGetProgramLogSize)(Opaque, size_t*);
  int (*nvrtcGetProgramLog)(Opaque, char*);
  int (*nvrtcGetCUBINSize)(Opaque, size_t*);
  int (*nvrtcGetCUBIN)(Opaque, char*);
};

template <typename F>
bool Load(void* lib, const char* name, F*& fn) {
  fn = reinterpret_cast<F*>(dlsym(lib, name));
  if (fn == nullptr) std::printf("missing symbol %s\n", name);
  return fn != nullptr;
}

void* OpenFirst(std::initializer_list<const char*> names) {
  for (const char* n : names) {
    if (void* lib = dlopen(n, RTLD_NOW | RTLD_LOCAL)) {
      std::printf("opened %s\n", n);
      return lib;
    }
  }
  return nullptr;
}

#define CHECK(call)                                               \
  do {                                                            \
    const int rc_ = (call);                                       \
    if (rc_ != 0) {                                               \
      std::printf("%s failed: %d\n", #call, rc_);                 \
      return 2;                                                   \
    }                                                             \
  } while (0)

// No driver (a machine without a GPU): NVRTC alone compiles the kernel for sm_90 (Hopper).
int CompileOnly(void* rtc, Nvrtc& n) {
  if (!Load(rtc, "nvrtcVersion", n.nvrtcVersion) || !Load(rtc, "nvrtcCreateProgram", n.nvrtcCreateProgram) ||
      !Load(rtc, "nvrtcCompileProgram", n.nvrtcCompileProgram) || !Load(rtc, "nvrtcGetCUBINSize", n.nvrtcGetCUBINSize) ||
      !Load(rtc, "nvrtcGetProgramLogSize", n.nvrtcGetProgramLogSize) || !Load(rtc, "nvrtcGetProgramLog", n.nvrtcGetProgramLog))
    return 2;
  int major = 0, minor = 0;
  CHECK(n.nvrtcVersion(&major, &minor));
  Opaque prog = nullptr;
  CHECK(n.nvrtcCreateProgram(&prog, kKernel, "probe.cu", 0, nullptr, nullptr));
  const char* options[] = {"--gpu-architecture=sm_90", "--fmad=false", "--std=c++17"};
  const int compiled = n.nvrtcCompileProgram(prog, 3, options);
  size_t log_size = 0, cubin_size = 0;
  n.nvrtcGetProgramLogSize(prog, &log_size);
  std::string log(log_size, '\0');
  n.nvrtcGetProgramLog(prog, log.data());
  if (compiled == 0) n.nvrtcGetCUBINSize(prog, &cubin_size);
  std::printf("NVRTC %d.%d, no driver: compile for sm_90 %s (cubin %zu bytes) %s\n", major, minor,
              compiled == 0 ? "ok" : "FAILED", cubin_size, log.c_str());
  return 2;
}

}  // namespace

int main() {
  void* cuda = OpenFirst({"libcuda.so.1", "libcuda.so"});
  void* rtc = OpenFirst({"libnvrtc.so", "libnvrtc.so.13", "libnvrtc.so.12"});
  Driver d{};
  Nvrtc n{};
  if (cuda == nullptr || rtc == nullptr) {
    std::printf("libcuda %s, libnvrtc %s\n", cuda ? "found" : "missing", rtc ? "found" : "missing");
    return rtc == nullptr ? 2 : CompileOnly(rtc, n);
  }
  bool ok = Load(cuda, "cuInit", d.cuInit) && Load(cuda, "cuDriverGetVersion", d.cuDriverGetVersion) &&
            Load(cuda, "cuDeviceGet", d.cuDeviceGet) && Load(cuda, "cuDeviceGetName", d.cuDeviceGetName) &&
            Load(cuda, "cuDeviceGetAttribute", d.cuDeviceGetAttribute) &&
            Load(cuda, "cuDevicePrimaryCtxRetain", d.cuDevicePrimaryCtxRetain) &&
            Load(cuda, "cuCtxSetCurrent", d.cuCtxSetCurrent) && Load(cuda, "cuModuleLoadData", d.cuModuleLoadData) &&
            Load(cuda, "cuModuleGetFunction", d.cuModuleGetFunction) && Load(cuda, "cuMemAlloc_v2", d.cuMemAlloc) &&
            Load(cuda, "cuMemcpyDtoH_v2", d.cuMemcpyDtoH) && Load(cuda, "cuLaunchKernel", d.cuLaunchKernel) &&
            Load(cuda, "cuCtxSynchronize", d.cuCtxSynchronize);
  ok = ok && Load(rtc, "nvrtcVersion", n.nvrtcVersion) && Load(rtc, "nvrtcCreateProgram", n.nvrtcCreateProgram) &&
       Load(rtc, "nvrtcCompileProgram", n.nvrtcCompileProgram) &&
       Load(rtc, "nvrtcGetProgramLogSize", n.nvrtcGetProgramLogSize) &&
       Load(rtc, "nvrtcGetProgramLog", n.nvrtcGetProgramLog) && Load(rtc, "nvrtcGetCUBINSize", n.nvrtcGetCUBINSize) &&
       Load(rtc, "nvrtcGetCUBIN", n.nvrtcGetCUBIN);
  if (!ok) return 2;

  CHECK(d.cuInit(0));
  int driver = 0, major = 0, minor = 0;
  CHECK(d.cuDriverGetVersion(&driver));
  CHECK(n.nvrtcVersion(&major, &minor));
  CUdevice dev = 0;
  CHECK(d.cuDeviceGet(&dev, 0));
  char name[256] = {};
  CHECK(d.cuDeviceGetName(name, sizeof name, dev));
  int cc_major = 0, cc_minor = 0, sms = 0;
  CHECK(d.cuDeviceGetAttribute(&cc_major, 75, dev));  // CU_DEVICE_ATTRIBUTE_COMPUTE_CAPABILITY_MAJOR
  CHECK(d.cuDeviceGetAttribute(&cc_minor, 76, dev));  // ..._MINOR
  CHECK(d.cuDeviceGetAttribute(&sms, 16, dev));       // CU_DEVICE_ATTRIBUTE_MULTIPROCESSOR_COUNT
  std::printf("device %s, sm_%d%d, %d SMs; driver API %d; NVRTC %d.%d\n", name, cc_major, cc_minor, sms, driver,
              major, minor);

  Opaque ctx = nullptr;
  CHECK(d.cuDevicePrimaryCtxRetain(&ctx, dev));
  CHECK(d.cuCtxSetCurrent(ctx));
  const auto t0 = std::chrono::steady_clock::now();
  Opaque prog = nullptr;
  CHECK(n.nvrtcCreateProgram(&prog, kKernel, "probe.cu", 0, nullptr, nullptr));
  const std::string arch = "--gpu-architecture=sm_" + std::to_string(cc_major) + std::to_string(cc_minor);
  const char* options[] = {arch.c_str(), "--fmad=false", "--std=c++17"};
  const int compiled = n.nvrtcCompileProgram(prog, 3, options);
  size_t log_size = 0;
  n.nvrtcGetProgramLogSize(prog, &log_size);
  std::string log(log_size, '\0');
  n.nvrtcGetProgramLog(prog, log.data());
  if (compiled != 0) {
    std::printf("NVRTC compile failed (%d): %s\n", compiled, log.c_str());
    return 2;
  }
  size_t cubin_size = 0;
  CHECK(n.nvrtcGetCUBINSize(prog, &cubin_size));
  std::vector<char> cubin(cubin_size);
  CHECK(n.nvrtcGetCUBIN(prog, cubin.data()));
  const double compile_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("NVRTC: cubin %zu bytes in %.3f s\n", cubin_size, compile_s);

  Opaque module = nullptr, fn = nullptr;
  CHECK(d.cuModuleLoadData(&module, cubin.data()));
  CHECK(d.cuModuleGetFunction(&fn, module, "probe"));
  unsigned long long count = 1ull << 24;
  CUdeviceptr out = 0;
  CHECK(d.cuMemAlloc(&out, count * sizeof(double)));
  void* args[] = {&out, &count};
  const unsigned block = 256, grid = static_cast<unsigned>((count + block - 1) / block);
  CHECK(d.cuLaunchKernel(fn, grid, 1, 1, block, 1, 1, 0, nullptr, args, nullptr));
  CHECK(d.cuCtxSynchronize());
  const auto t1 = std::chrono::steady_clock::now();
  CHECK(d.cuLaunchKernel(fn, grid, 1, 1, block, 1, 1, 0, nullptr, args, nullptr));
  CHECK(d.cuCtxSynchronize());
  const double kernel_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  std::vector<double> gpu(count), cpu(count);
  CHECK(d.cuMemcpyDtoH(gpu.data(), out, count * sizeof(double)));
  const auto t2 = std::chrono::steady_clock::now();
  ProbeCpu(cpu.data(), count);
  const double cpu_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t2).count();
  std::size_t differ = 0;
  for (std::size_t i = 0; i < count; ++i) differ += std::memcmp(&gpu[i], &cpu[i], sizeof(double)) != 0;
  std::printf("%llu values: %zu differ in a bit; GPU %.2f ms (%.0f M/s), one CPU core %.0f ms\n", count, differ,
              kernel_s * 1e3, count / kernel_s / 1e6, cpu_s * 1e3);
  return differ == 0 ? 0 : 1;
}
