// model/plugins.cc — models built at run time (vlt/models.h BuildModel, FindModel;
// docs/custom-models.md "Without rebuilding vlt"): vlt-gen derives a spec into C++ (`--plugin`), the
// system's compiler makes a shared library of it against vlt's public headers, the library goes
// into a per-user cache keyed by the spec's bytes and vlt's version and model ABI, and FindModel
// loads it by name (dlopen; the entry point vlt_model_plugin, vlt/model_info.h).
//
// The cache is the user's own: never a shared directory (no /tmp fallback), created 0700, and an
// entry is loaded only when the user owns it and nobody else may write it (a library in the cache
// runs code when loaded).
//
// An entry <name>/ holds model-<key>.so (one file per build: dlopen of a path already loaded would
// return the old library, so a rebuild in the same process needs a new path), model-<key>.h (the
// generated header it was compiled from, for the GPU kernel), spec.toml, build.log
// and `key`, the file that says which library is current. A build derives and compiles in a
// private directory (mkdtemp), takes the entry's lock (flock on <name>.lock: builds of one name,
// from threads or processes, run one after the other), renames its library in and then replaces
// `key` by a rename: a reader sees the old key and library or the new ones, never half. Libraries of
// older keys are removed after an hour (a run that read the old key just before has long loaded it).
//
// Tools run with fork + execvp on argument vectors (no shell), output into a log, other descriptors
// closed.
#include <dlfcn.h>
#include <fcntl.h>
#include <pwd.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <chrono>
#include <cstdlib>
#include <cstring>
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

// The tools of a build tree and of the install prefix (compile definitions of this file,
// runtime/CMakeLists.txt).
#ifndef VLT_BUILD_VLT_GEN
#define VLT_BUILD_VLT_GEN ""
#endif
#ifndef VLT_BUILD_INCLUDE_DIR
#define VLT_BUILD_INCLUDE_DIR ""
#endif
#ifndef VLT_INSTALL_PREFIX
#define VLT_INSTALL_PREFIX ""
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

bool IsIdentifier(std::string_view name) {
  if (name.empty() || std::isdigit(static_cast<unsigned char>(name[0]))) return false;
  return name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_") ==
         std::string_view::npos;
}

// The key of a build: the spec's bytes, vlt's version and the model ABI.
// The cache entry's layout: 2 since the generated header is kept beside the library
// (model-<key>.h, for the GPU kernel); an entry of another layout is built again.
constexpr int kEntryLayout = 2;

std::string BuildKey(const std::string& spec_bytes) {
  return Sha256Bytes(spec_bytes + '\0' + VLT_VERSION + '\0' + std::to_string(kModelAbi) + '\0' +
                     std::to_string(kEntryLayout));
}

// The user's own directory: refuses one that another user owns or that others may write (a
// library loaded from it runs its code).
void CheckOwnDirectory(const fs::path& dir) {
  struct stat st {};
  if (::stat(dir.c_str(), &st) != 0) return;
  if (st.st_uid != ::getuid() || (st.st_mode & (S_IWGRP | S_IWOTH)) != 0) {
    throw InputError(
        dir.string() +
        ": the model cache must be the user's own and writable by nobody else (a model in it runs code "
        "when loaded)");
  }
}

// The status of a finished child: its exit code, or 128 + the signal that ended it.
int ExitCode(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 128;
}

// What a tool may use, so that no spec can hang `vlt model build` or a job that builds its model
// (GiNaC computes 2^(2^40) exactly while it parses): CPU seconds (each process; SIGXCPU, then
// SIGKILL 5 s later) and bytes of address space.
struct ToolLimits {
  rlim_t cpu_seconds;
  rlim_t address_space;
};
constexpr ToolLimits kGeneratorLimits{60, rlim_t{4} << 30};
constexpr ToolLimits kCompilerLimits{600, rlim_t{8} << 30};

// AddressSanitizer reserves terabytes of address space for its shadow: a build with it (the CI's
// sanitizer stage, whose vlt-gen has it too) limits the CPU time only.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kLimitAddressSpace = false;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kLimitAddressSpace = false;
#else
constexpr bool kLimitAddressSpace = true;
#endif
#else
constexpr bool kLimitAddressSpace = true;
#endif

// Runs argv[0] (found on PATH when it has no '/') with stdout and stderr into `log`, descriptors
// above 2 closed, within `limits`; its exit code (128 + the signal that ended it), 127 when it
// could not be started, -1 when its status is lost (the caller ignores SIGCHLD: the caller then
// judges by what it wrote).
int Run(const std::vector<std::string>& argv, const fs::path& log, const ToolLimits& limits) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) throw InputError("cannot start " + argv[0] + ": fork failed");
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0600);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
    }
    for (int other = 3; other < 1024; ++other) ::close(other);
    const rlimit cpu{limits.cpu_seconds, limits.cpu_seconds + 5};
    const rlimit memory{limits.address_space, limits.address_space};
    ::setrlimit(RLIMIT_CPU, &cpu);
    if (kLimitAddressSpace) ::setrlimit(RLIMIT_AS, &memory);
    ::execvp(args[0], args.data());
    ::_exit(127);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno == ECHILD) return -1;
    if (errno != EINTR) return 127;
  }
  return ExitCode(status);
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

// Where an installed vlt keeps vlt-gen and the headers: beside the executable (<prefix>/bin/vlt),
// then the prefix vlt was configured for (the Python module lives under <prefix>/lib).
std::vector<fs::path> Prefixes() {
  std::vector<fs::path> out;
  if (const fs::path exe = ExecutableDirectory(); !exe.empty()) out.push_back(exe.parent_path());
  if (std::strlen(VLT_INSTALL_PREFIX) > 0) out.emplace_back(VLT_INSTALL_PREFIX);
  return out;
}

fs::path FindGenerator() {
  if (const std::string env = Env("VLT_GEN"); !env.empty()) return env;
  for (const fs::path& prefix : Prefixes()) {
    if (IsFile(prefix / "bin" / "vlt-gen")) return prefix / "bin" / "vlt-gen";
  }
  if (const fs::path beside = ExecutableDirectory() / "vlt-gen"; IsFile(beside)) return beside;
  if (IsFile(VLT_BUILD_VLT_GEN)) return VLT_BUILD_VLT_GEN;
  throw InputError(
      "vlt model build: vlt-gen not found ($VLT_GEN, <prefix>/bin/vlt-gen or the build tree's "
      "symbolic/vlt-gen; "
      "install vlt with it, or build it: ninja -C build vlt-gen)");
}

fs::path FindIncludeDirectory() {
  std::vector<fs::path> candidates;
  if (const std::string env = Env("VLT_INCLUDE_DIR"); !env.empty()) candidates.emplace_back(env);
  for (const fs::path& prefix : Prefixes()) candidates.push_back(prefix / "include");
  candidates.emplace_back(VLT_BUILD_INCLUDE_DIR);
  for (const fs::path& dir : candidates) {
    if (IsFile(dir / "vlt" / "model_info.h")) return dir;
  }
  throw InputError(
      "vlt model build: vlt's headers not found (<prefix>/include/vlt/model_info.h; set VLT_INCLUDE_DIR)");
}

// The compiler: $CXX split at spaces ("ccache c++"), else c++.
std::vector<std::string> Compiler() {
  std::vector<std::string> words;
  std::istringstream in(Env("CXX"));
  for (std::string w; in >> w;) words.push_back(w);
  if (words.empty()) words.emplace_back("c++");
  return words;
}

// An exclusive lock on a file, released when destroyed.
class FileLock {
 public:
  explicit FileLock(const fs::path& path) : fd_(::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600)) {
    if (fd_ < 0)
      throw InputError(path.string() + ": cannot lock the model cache (" + std::strerror(errno) + ")");
    while (::flock(fd_, LOCK_EX) != 0 && errno == EINTR) {}
  }
  ~FileLock() { ::close(fd_); }
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  int fd_;
};

// A private directory (mkdtemp) in the cache, removed when destroyed.
class WorkDirectory {
 public:
  explicit WorkDirectory(const fs::path& cache) {
    std::string pattern = (cache / ".build-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) {
      throw InputError(cache.string() + ": cannot build in the model cache (" + std::strerror(errno) + ")");
    }
    path_ = pattern;
  }
  ~WorkDirectory() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  WorkDirectory(const WorkDirectory&) = delete;
  WorkDirectory& operator=(const WorkDirectory&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// The current library of a cache entry (its key file names it), or empty.
fs::path CurrentLibrary(const fs::path& entry) {
  const std::string key = ReadBytes(entry / "key");
  if (key.size() < 16) return {};
  const fs::path library = entry / ("model-" + key.substr(0, 16) + ".so");
  return IsFile(library) ? library : fs::path();
}

// The models loaded from the cache, by library path (kept loaded: their ModelInfo is used for the
// process; a rebuilt model has a new path).
struct Loaded {
  std::mutex mutex;
  std::map<std::string, const ModelInfo*, std::less<>> by_library;
  // The generated header beside each library (model-<key>.h), read when the library was loaded.
  std::map<const ModelInfo*, std::string> source;
};
Loaded& LoadedModels() {
  static Loaded loaded;
  return loaded;
}

const ModelInfo* LoadLibrary(const std::string& name, const fs::path& library) {
  const std::string where = "model '" + name + "': " + library.string();
  CheckOwnDirectory(library.parent_path());
  struct stat st {};
  if (::stat(library.c_str(), &st) != 0 || st.st_uid != ::getuid() ||
      (st.st_mode & (S_IWGRP | S_IWOTH)) != 0) {
    throw InputError(where + ": not the user's own, or writable by others: not loaded");
  }
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

// The generated header beside `library` (model-<key>.h), read as the library is: only where the
// user owns it and nobody else may write it (opened without following a link), and only a header
// as vlt-gen writes it — no preprocessor line but `#pragma once` and `#include <cmath>`, so that
// nothing can redefine what the GPU kernel compiles. Empty otherwise (the GPU path then runs the
// model on the CPU and says why).
std::string KeptSource(const fs::path& library) {
  fs::path header = library;
  header.replace_extension(".h");
  const int fd = ::open(header.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return "";
  struct stat st {};
  std::string text;
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_uid == ::getuid() &&
      (st.st_mode & (S_IWGRP | S_IWOTH)) == 0) {
    char buffer[65536];
    for (ssize_t got; (got = ::read(fd, buffer, sizeof buffer)) > 0;) text.append(buffer, static_cast<std::size_t>(got));
  }
  ::close(fd);
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    const std::size_t at = line.find_first_not_of(" \t");
    if (at != std::string::npos && line[at] == '#' && line != "#pragma once" && line != "#include <cmath>") return "";
  }
  return text;
}

// Derives the spec into `src` with vlt-gen; its one line on a spec error.
void Derive(const fs::path& spec_path, const fs::path& src, const fs::path& log) {
  const int gen = Run(
      {FindGenerator().string(), "--plugin", fs::absolute(spec_path).string(), "--out", src.string()}, log,
      kGeneratorLimits);
  if (gen == 0 || (gen == -1 && IsFile(src / "plugin.cc"))) return;
  if (gen == 127) throw InputError("vlt model build: cannot run vlt-gen (" + FindGenerator().string() + ")");
  if (gen == 128 + SIGXCPU || gen == 128 + SIGKILL) {
    throw InputError(fs::absolute(spec_path).string() + ": vlt-gen stopped after " +
                     std::to_string(kGeneratorLimits.cpu_seconds) +
                     " s of CPU time: the spec's expressions are too large to derive");
  }
  std::string line = FirstLine(log, "error:");
  const std::string prefix = "vlt-gen: error: ";
  if (line.rfind(prefix, 0) == 0) line = line.substr(prefix.size());
  throw InputError(line.empty() ? "vlt model build: vlt-gen failed (exit " + std::to_string(gen) + ")"
                                : line);
}

// Compiles the derived sources into `library`: the kernels as the runtime compiles its own (IEEE, no
// contraction, no assertions), every symbol but the entry point hidden (two models never meet).
void Compile(const std::string& name, const fs::path& src, const fs::path& library, const fs::path& log,
             const fs::path& kept_log) {
  std::vector<std::string> argv = Compiler();
  const std::string compiler = argv.front();
  for (const std::string& flag :
       {std::string("-std=c++20"), std::string("-O3"), std::string("-DNDEBUG"), std::string("-fPIC"),
        std::string("-shared"), std::string("-fvisibility=hidden"), std::string("-ffp-contract=off"),
        std::string("-fno-math-errno"), "-I" + src.string(), "-I" + FindIncludeDirectory().string(),
        std::string("-I") + VLT_EIGEN_INCLUDE_DIR, (src / "generated" / (name + ".cc")).string(),
        (src / "plugin.cc").string(), std::string("-o"), library.string()}) {
    argv.push_back(flag);
  }
  const int cc = Run(argv, log, kCompilerLimits);
  if (cc == 127) throw InputError("vlt model build: no C++ compiler found ('" + compiler + "'; set CXX)");
  if (cc == 0 || (cc == -1 && IsFile(library))) return;
  std::error_code ec;
  fs::copy_file(log, kept_log, fs::copy_options::overwrite_existing, ec);
  const std::string first = FirstLine(log, "error");
  throw InputError(
      "vlt model build: the compiler failed (" +
      (cc > 128 ? "killed by signal " + std::to_string(cc - 128) : "exit " + std::to_string(cc)) + ")" +
      (first.empty() ? "" : ": " + first) + " (log: " + kept_log.string() + ")");
}

// Libraries of older keys, an hour after they were replaced.
void RemoveStaleLibraries(const fs::path& entry, const fs::path& current) {
  std::error_code ec;
  const auto now = fs::file_time_type::clock::now();
  for (const auto& f : fs::directory_iterator(entry, ec)) {
    const std::string file = f.path().filename().string();
    if (f.path() == current || file.rfind("model-", 0) != 0) continue;
    if (now - fs::last_write_time(f.path(), ec) > std::chrono::hours(1)) fs::remove(f.path(), ec);
  }
}

}  // namespace

fs::path ModelCacheDirectory() {
  if (const std::string env = Env("VLT_MODEL_CACHE"); !env.empty()) return env;
  if (const std::string xdg = Env("XDG_CACHE_HOME"); !xdg.empty()) return fs::path(xdg) / "vlt" / "models";
  std::string home = Env("HOME");
  if (home.empty()) {
    if (const passwd* pw = ::getpwuid(::getuid()); pw != nullptr && pw->pw_dir != nullptr) home = pw->pw_dir;
  }
  if (home.empty()) throw InputError("no model cache: set VLT_MODEL_CACHE (HOME is not set)");
  return fs::path(home) / ".cache" / "vlt" / "models";
}

std::span<const ModelInfo* const> AllModels() { return {generated::kModels, generated::kNumModels}; }

const ModelInfo* FindModel(std::string_view name) {
  for (const ModelInfo* model : AllModels()) {
    if (name == model->name) return model;
  }
  // A model name is an identifier (vlt-gen's rule): anything else is no path into the cache.
  if (!IsIdentifier(name)) return nullptr;
  const fs::path entry = ModelCacheDirectory() / std::string(name);
  const fs::path library = CurrentLibrary(entry);
  if (library.empty()) return nullptr;
  Loaded& loaded = LoadedModels();
  const std::lock_guard<std::mutex> lock(loaded.mutex);
  if (const auto it = loaded.by_library.find(library.string()); it != loaded.by_library.end())
    return it->second;
  const ModelInfo* model = LoadLibrary(std::string(name), library);
  loaded.by_library.emplace(library.string(), model);
  if (std::string source = KeptSource(library); !source.empty()) loaded.source.emplace(model, std::move(source));
  return model;
}

std::string BuiltModelSource(const ModelInfo& model) {
  Loaded& loaded = LoadedModels();
  const std::lock_guard<std::mutex> lock(loaded.mutex);
  const auto it = loaded.source.find(&model);
  return it == loaded.source.end() ? std::string() : it->second;
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
    if (!IsIdentifier(name) || !entry.is_directory(ec)) continue;
    BuiltModel m;
    m.name = name;
    m.library = CurrentLibrary(entry.path());
    if (m.library.empty()) continue;
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
  // The model's name is the spec's file stem (vlt-gen refuses a spec whose [model] name differs).
  const std::string name = spec_path.stem().string();
  if (!IsIdentifier(name)) {
    throw InputError(spec_path.string() +
                     ": a spec is named after its model (<name>.toml, the name an identifier)");
  }
  for (const ModelInfo* m : AllModels()) {
    if (name == m->name) {
      throw InputError(spec_path.string() + ": name: a built-in model is called '" + name +
                       "' (give yours another name)");
    }
  }
  const std::string spec_bytes = ReadBytes(spec_path);
  const std::string key = BuildKey(spec_bytes);
  const fs::path cache = ModelCacheDirectory();
  const fs::path entry = cache / name;
  // Unchanged: found without deriving, compiling or writing (a read-only cache will do) — with
  // its header beside it (the GPU kernel's source; built again where it went missing).
  const auto complete = [&] {
    fs::path header = CurrentLibrary(entry);
    return !header.empty() && IsFile(header.replace_extension(".h"));
  };
  if (ReadBytes(entry / "key") == key && complete()) return {name, CurrentLibrary(entry), true, 0.0};

  fs::create_directories(cache, ec);
  if (ec) throw InputError(cache.string() + ": cannot create the model cache (" + ec.message() + ")");
  fs::permissions(cache, fs::perms::owner_all, fs::perm_options::replace, ec);
  CheckOwnDirectory(cache);
  const FileLock lock(cache / ("." + name + ".lock"));
  // Another build of the same spec may have finished while this one waited for the lock.
  if (ReadBytes(entry / "key") == key && complete()) return {name, CurrentLibrary(entry), true, 0.0};

  const WorkDirectory work(cache);
  const fs::path library = work.path() / "model.so";
  Derive(spec_path, work.path() / "src", work.path() / "derive.log");
  Compile(name, work.path() / "src", library, work.path() / "compile.log",
          cache / (name + ".failed-build.log"));

  // Install: the library under its key's name, then the key by a rename (readers: old or new).
  fs::create_directories(entry, ec);
  fs::permissions(entry, fs::perms::owner_all, fs::perm_options::replace, ec);
  const fs::path installed = entry / ("model-" + key.substr(0, 16) + ".so");
  fs::rename(library, installed, ec);
  if (ec) throw InputError(installed.string() + ": cannot install the model (" + ec.message() + ")");
  // The generated header beside it, under the same key (the GPU kernel compiles its Forward).
  fs::path header = installed;
  header.replace_extension(".h");
  WriteBytes(header, ReadBytes(work.path() / "src" / "generated" / (name + ".h")));
  WriteBytes(entry / "spec.toml", spec_bytes);
  WriteBytes(entry / "build.log",
             ReadBytes(work.path() / "derive.log") + ReadBytes(work.path() / "compile.log"));
  WriteBytes(work.path() / "key", key);
  fs::rename(work.path() / "key", entry / "key", ec);
  if (ec) throw InputError((entry / "key").string() + ": cannot install the model (" + ec.message() + ")");
  fs::remove(cache / (name + ".failed-build.log"), ec);
  RemoveStaleLibraries(entry, installed);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return {name, installed, false, seconds};
}

}  // namespace vlt
