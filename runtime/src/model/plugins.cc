// model/plugins.cc — models built at run time (vlt/models.h BuildModel, FindModel;
// docs/custom-models.md "Without rebuilding vlt"): vlt-gen derives a spec into C++ (`--plugin`), the
// system's compiler makes a shared library of it against vlt's public headers, the library goes
// into a per-user cache keyed by the spec's bytes and vlt's version and model ABI, and FindModel
// loads it by name (dlopen; the entry point vlt_model_plugin, vlt/model_info.h).
//
// Tools are run with fork + execvp on argument vectors (no shell: a spec path is never parsed as a
// command), their output into the entry's build.log. A build is made in a directory of its own and
// replaces the cache's entry with two renames, so a run that loads the model meanwhile sees the old
// library or the new one, never half of one.
#include <dlfcn.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "vlt/calibration.h"  // Sha256Bytes (base/sha256.cc)
#include "vlt/error.h"
#include "vlt/models.h"

namespace vlt {
namespace {

namespace fs = std::filesystem;

// The tools of a build tree (compile definitions of this file, runtime/CMakeLists.txt), tried last.
#ifndef VLT_BUILD_VLT_GEN
#define VLT_BUILD_VLT_GEN ""
#endif
#ifndef VLT_BUILD_INCLUDE_DIR
#define VLT_BUILD_INCLUDE_DIR ""
#endif
#ifndef VLT_EIGEN_INCLUDE_DIR
#define VLT_EIGEN_INCLUDE_DIR "/usr/include/eigen3"
#endif

std::string Env(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::string(v) : std::string();
}

// The directory of the running program (vlt, or python for the module).
fs::path ExecutableDirectory() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : exe.parent_path();
}

bool IsFile(const fs::path& p) {
  std::error_code ec;
  return !p.empty() && fs::is_regular_file(p, ec);
}

std::string ReadBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void WriteBytes(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << bytes;
  out.close();
  if (!out) throw InputError(p.string() + ": cannot write (disk full?)");
}

// The key of a build: the spec's bytes, vlt's version and the model ABI.
std::string BuildKey(const std::string& spec_bytes) {
  return Sha256Bytes(spec_bytes + '\0' + VLT_VERSION + '\0' + std::to_string(kModelAbi));
}

// Runs argv[0] (found on PATH when it has no '/') with stdout and stderr appended to `log`; its exit
// status, 127 when it could not be started.
int Run(const std::vector<std::string>& argv, const fs::path& log) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) throw InputError("cannot start " + argv[0] + ": fork failed");
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::close(fd);
    }
    ::execvp(args[0], args.data());
    ::_exit(127);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return 127;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

// The first line of `log` holding `marker` (the compiler's first error), else its first line.
std::string FirstLine(const fs::path& log, const std::string& marker) {
  std::ifstream in(log);
  std::string line, first;
  while (std::getline(in, line)) {
    if (first.empty() && !line.empty()) first = line;
    if (line.find(marker) != std::string::npos) return line;
  }
  return first;
}

fs::path FindGenerator() {
  if (const std::string env = Env("VLT_GEN"); !env.empty()) return env;
  if (const fs::path beside = ExecutableDirectory() / "vlt-gen"; IsFile(beside)) return beside;
  if (IsFile(VLT_BUILD_VLT_GEN)) return VLT_BUILD_VLT_GEN;
  throw InputError(
      "vlt model build: vlt-gen not found (beside vlt, $VLT_GEN or the build tree's symbolic/vlt-gen; "
      "install vlt with it, or build it: ninja -C build vlt-gen)");
}

fs::path FindIncludeDirectory() {
  std::vector<fs::path> candidates;
  if (const std::string env = Env("VLT_INCLUDE_DIR"); !env.empty()) candidates.emplace_back(env);
  candidates.push_back(ExecutableDirectory().parent_path() / "include");  // <prefix>/bin/vlt
  candidates.emplace_back(VLT_BUILD_INCLUDE_DIR);
  for (const fs::path& dir : candidates) {
    if (IsFile(dir / "vlt" / "model_info.h")) return dir;
  }
  throw InputError(
      "vlt model build: vlt's headers not found (<prefix>/include/vlt/model_info.h; set VLT_INCLUDE_DIR)");
}

// The models loaded from the cache, by name (kept loaded: their ModelInfo is used for the process).
struct Loaded {
  std::mutex mutex;
  std::map<std::string, const ModelInfo*, std::less<>> models;
};
Loaded& LoadedModels() {
  static Loaded loaded;
  return loaded;
}

const ModelInfo* LoadLibrary(const std::string& name, const fs::path& library) {
  const std::string where = "model '" + name + "': " + library.string();
  void* handle = ::dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* e = ::dlerror();
    throw InputError(where + ": cannot load (" + std::string(e ? e : "dlopen failed") +
                     "); rebuild it with vlt model build");
  }
  const auto entry = reinterpret_cast<ModelPluginFn>(::dlsym(handle, "vlt_model_plugin"));
  if (entry == nullptr) throw InputError(where + ": not a vlt model (no vlt_model_plugin)");
  int abi = 0;
  const ModelInfo* model = entry(&abi);
  if (abi != kModelAbi) {
    throw InputError(where + ": built for another vlt (model ABI " + std::to_string(abi) + ", this vlt " +
                     std::to_string(kModelAbi) + "); rebuild it with vlt model build");
  }
  if (model == nullptr || name != model->name) throw InputError(where + ": holds another model");
  return model;
}

}  // namespace

fs::path ModelCacheDirectory() {
  if (const std::string env = Env("VLT_MODEL_CACHE"); !env.empty()) return env;
  if (const std::string xdg = Env("XDG_CACHE_HOME"); !xdg.empty()) return fs::path(xdg) / "vlt" / "models";
  const std::string home = Env("HOME");
  return (home.empty() ? fs::temp_directory_path() : fs::path(home) / ".cache") / "vlt" / "models";
}

std::span<const ModelInfo* const> AllModels() { return {generated::kModels, generated::kNumModels}; }

const ModelInfo* FindModel(std::string_view name) {
  for (const ModelInfo* model : AllModels()) {
    if (name == model->name) return model;
  }
  // A model name is an identifier (vlt-gen's rule): anything else is no path into the cache.
  if (name.empty() ||
      name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_") !=
          std::string_view::npos) {
    return nullptr;
  }
  Loaded& loaded = LoadedModels();
  const std::lock_guard<std::mutex> lock(loaded.mutex);
  if (const auto it = loaded.models.find(name); it != loaded.models.end()) return it->second;
  const fs::path library = ModelCacheDirectory() / std::string(name) / "model.so";
  if (!IsFile(library)) return nullptr;
  const ModelInfo* model = LoadLibrary(std::string(name), library);
  loaded.models.emplace(std::string(name), model);
  return model;
}

int FindParam(const ModelInfo& model, std::string_view name) {
  for (int k = 0; k < model.num_params; ++k) {
    if (name == model.params[k].name) return k;
  }
  return -1;
}

std::vector<BuiltModel> BuiltModels() {
  std::vector<BuiltModel> out;
  std::error_code ec;
  const fs::path cache = ModelCacheDirectory();
  for (const auto& entry : fs::directory_iterator(cache, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name[0] == '.' || !IsFile(entry.path() / "model.so")) continue;
    BuiltModel m;
    m.name = name;
    m.library = entry.path() / "model.so";
    m.spec = entry.path() / "spec.toml";
    m.current = IsFile(m.spec) && ReadBytes(entry.path() / "key") == BuildKey(ReadBytes(m.spec));
    out.push_back(m);
  }
  std::sort(out.begin(), out.end(), [](const BuiltModel& a, const BuiltModel& b) { return a.name < b.name; });
  return out;
}

ModelBuild BuildModel(const fs::path& spec_path) {
  const auto start = std::chrono::steady_clock::now();
  std::error_code ec;
  if (!fs::is_regular_file(spec_path, ec))
    throw InputError(spec_path.string() + ": cannot read the model spec");
  const std::string spec_bytes = ReadBytes(spec_path);
  const std::string key = BuildKey(spec_bytes);
  const fs::path cache = ModelCacheDirectory();
  fs::create_directories(cache, ec);
  if (ec) throw InputError(cache.string() + ": cannot create the model cache (" + ec.message() + ")");

  // Derive: vlt-gen writes the sources and prints the model's name (a spec error is its one line).
  const fs::path work = cache / (".build-" + std::to_string(::getpid()));
  fs::remove_all(work, ec);
  fs::create_directories(work / "src", ec);
  const fs::path log = work / "build.log";
  struct Cleanup {
    fs::path dir;
    ~Cleanup() {
      std::error_code e;
      fs::remove_all(dir, e);
    }
  } cleanup{work};
  const int gen = Run({FindGenerator().string(), "--plugin", fs::absolute(spec_path).string(), "--out",
                       (work / "src").string()},
                      log);
  if (gen != 0) {
    std::string line = FirstLine(log, "error:");
    const std::string prefix = "vlt-gen: error: ";
    if (line.rfind(prefix, 0) == 0) line = line.substr(prefix.size());
    throw InputError(gen == 127 ? "vlt model build: cannot run vlt-gen" : line);
  }
  std::string name;
  {
    std::ifstream in(log);
    std::string line;
    while (std::getline(in, line)) {
      if (!line.empty()) name = line;  // its last line
    }
  }
  for (const ModelInfo* m : AllModels()) {
    if (name == m->name) {
      throw InputError(spec_path.string() + ": name: a built-in model is called '" + name +
                       "' (give yours another name)");
    }
  }
  const fs::path entry = cache / name;
  if (IsFile(entry / "model.so") && ReadBytes(entry / "key") == key) {
    return {name, entry / "model.so", true, 0.0};
  }

  // Compile: the kernels as the runtime compiles its own (IEEE, no contraction), every symbol but
  // the entry point hidden (two models' internals never meet).
  const std::string compiler = Env("CXX").empty() ? "c++" : Env("CXX");
  const fs::path library = work / "model.so";
  const fs::path include = FindIncludeDirectory();
  const int cc =
      Run({compiler, "-std=c++20", "-O3", "-fPIC", "-shared", "-fvisibility=hidden", "-ffp-contract=off",
           "-fno-math-errno", "-I" + (work / "src").string(), "-I" + include.string(),
           std::string("-I") + VLT_EIGEN_INCLUDE_DIR, (work / "src" / "generated" / (name + ".cc")).string(),
           (work / "src" / "plugin.cc").string(), "-o", library.string()},
          log);
  if (cc == 127) throw InputError("vlt model build: no C++ compiler found ('" + compiler + "'; set CXX)");
  if (cc != 0 || !IsFile(library)) {
    throw InputError("vlt model build: " + spec_path.string() +
                     ": the compiler failed: " + FirstLine(log, "error"));
  }

  // Replace the cache's entry whole: the new one is renamed in, the old one out.
  const fs::path staged = cache / ("." + name + ".new-" + std::to_string(::getpid()));
  fs::remove_all(staged, ec);
  fs::create_directories(staged, ec);
  fs::rename(library, staged / "model.so", ec);
  WriteBytes(staged / "spec.toml", spec_bytes);
  WriteBytes(staged / "key", key);
  fs::copy_file(log, staged / "build.log", fs::copy_options::overwrite_existing, ec);
  const fs::path old = cache / ("." + name + ".old-" + std::to_string(::getpid()));
  if (fs::exists(entry, ec)) fs::rename(entry, old, ec);
  fs::rename(staged, entry, ec);
  if (ec) throw InputError(entry.string() + ": cannot replace the cached model (" + ec.message() + ")");
  fs::remove_all(old, ec);
  {
    // A model this process loaded before stays loaded; a later process loads the new library.
    Loaded& loaded = LoadedModels();
    const std::lock_guard<std::mutex> lock(loaded.mutex);
    loaded.models.erase(name);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return {name, entry / "model.so", false, seconds};
}

}  // namespace vlt
