// output/output_directory.cc — an output directory replaced as one transaction (vlt/results.h
// OutputDirectory; docs/cli.md "Outputs").
//
// The complete new set of files is written into a staging directory beside the target
// (".<name>.vlt-new-<pid>"), then swapped in with renameat2(RENAME_EXCHANGE) — one atomic step on
// Linux: a reader sees the old set or the new set, never a mixture — and the old set is removed.
// Where the file system cannot exchange, two renames (the target is absent for an instant).
// A directory vlt did not write is never emptied: the check runs before anything is computed.
// SIGINT/SIGTERM while the staging directory exists remove it (async-signal-safe unlink/rmdir on
// paths prepared beforehand) and then end the process as the signal would.
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <array>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>

#include "mpi/ranks.h"
#include "vlt/error.h"
#include "vlt/results.h"

namespace vlt {

namespace {

namespace fs = std::filesystem;

// What the signal handler removes: fixed buffers, filled before the staging directory exists.
constexpr int kMaxStaged = 64;
constexpr std::size_t kMaxPath = 4096;
char g_staged_files[kMaxStaged][kMaxPath];
char g_staging_dir[kMaxPath];
volatile std::sig_atomic_t g_staged_count = 0;
volatile std::sig_atomic_t g_staging_active = 0;

extern "C" void RemoveStagingOnSignal(int signal_number) {
  if (g_staging_active) {
    for (int i = 0; i < g_staged_count; ++i) ::unlink(g_staged_files[i]);
    ::rmdir(g_staging_dir);
  }
  std::signal(signal_number, SIG_DFL);
  std::raise(signal_number);
}

bool CopyPath(char* buffer, const fs::path& p) {
  const std::string s = p.string();
  if (s.size() + 1 > kMaxPath) return false;
  std::memcpy(buffer, s.c_str(), s.size() + 1);
  return true;
}

// The names every vlt command writes: a directory holding only these (and the marker) was
// written by vlt, also by versions before the marker existed.
const std::set<std::string>& KnownOutputNames() {
  static const std::set<std::string> names = {kOutputMarker,
                                              "points.csv",
                                              "points.jsonl",
                                              "points.npy",
                                              "outputs.csv",
                                              "budget.csv",
                                              "tasks.csv",
                                              "results.json",
                                              "report.html",
                                              "map.csv",
                                              "map.html",
                                              "tests.csv",
                                              "sensitivity.csv",
                                              "simulated_readings.csv",
                                              "simulated_calibration.toml",
                                              "calibration.toml",
                                              "parameters.csv",
                                              "correlation.csv",
                                              "identifiability.csv",
                                              "targets.csv",
                                              "residuals.csv",
                                              "plan.json",
                                              "station_map.csv",
                                              "station_map.html",
                                              "planned_job.toml"};
  return names;
}

// The names a marker lists (one per line after its first): what the run that left it wrote, so a
// run of the same command into the same directory recognises every file (simulated_<station>.csv,
// distances.csv, ... beyond the fixed names above).
std::set<std::string> NamesInMarker(const fs::path& marker) {
  std::set<std::string> names;
  std::ifstream in(marker);
  std::string line;
  for (bool first = true; std::getline(in, line); first = false) {
    if (!first && !line.empty()) names.insert(line);
  }
  return names;
}

fs::path Normalised(const fs::path& p) {
  fs::path n = p.lexically_normal();
  if (n.has_filename()) return n;
  return n.parent_path();  // "out/" -> "out"
}

void RemoveQuietly(const fs::path& p) {
  std::error_code ec;
  fs::remove_all(p, ec);
}

// A staging (".<name>.vlt-new-<pid>") or old set (".vlt-old-<pid>") of `name` whose process is gone:
// left by a run that was killed (SIGKILL, power loss). One whose process lives is another run's
// transaction under way into the same directory, and is left alone (a pid reused since leaves a
// stale one behind, which the next run after that process ends removes).
bool LeftByADeadRun(const std::string& entry, const std::string& name) {  // name: StagingStem's
  for (const char* kind : {".vlt-new-", ".vlt-old-"}) {
    const std::string prefix = "." + name + kind;
    if (entry.rfind(prefix, 0) != 0) continue;
    const std::string digits = entry.substr(prefix.size());
    if (digits.empty() || digits.size() > 10 || digits.find_first_not_of("0123456789") != std::string::npos)
      return false;
    const long pid = std::stol(digits);
    if (pid <= 0 || pid == static_cast<long>(::getpid())) return pid > 0;
    return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
  }
  return false;
}

// The output directory's name as its staging and old sets' names hold it (".<stem>.vlt-new-<pid>"):
// the name, or, where the set's name would pass the 255 bytes a file name may have (an output
// directory named with 236 to 255 bytes is legal), its first bytes cut before a UTF-8 character,
// "~" and the FNV-1a hash of the whole name, so that two long names with a common start do not
// take (and clean up) each other's sets.
std::string StagingStem(const std::string& name) {
  constexpr std::size_t kMaxFileName = 255, kAround = 1 + 9 + 10;  // ".", ".vlt-new-", a pid's digits
  if (name.size() + kAround <= kMaxFileName) return name;
  std::uint64_t hash = 14695981039346656037ull;  // FNV-1a, 64 bits
  for (const char c : name) hash = (hash ^ static_cast<unsigned char>(c)) * 1099511628211ull;
  std::size_t keep = kMaxFileName - kAround - 17;  // "~" and 16 hexadecimal digits
  while (keep > 0 && (static_cast<unsigned char>(name[keep]) & 0xC0) == 0x80) --keep;  // not inside a character
  char tail[24];
  std::snprintf(tail, sizeof tail, "~%016llx", static_cast<unsigned long long>(hash));
  return name.substr(0, keep) + tail;
}

}  // namespace

void InstallOutputSignalHandlers() {
  struct sigaction action {};
  action.sa_handler = RemoveStagingOnSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

OutputDirectory::OutputDirectory(const fs::path& target) : target_(Normalised(target)) {
  if (target_.empty() || target_ == "." || target_ == "..") {
    throw InputError(
        target.string() +
        ": the output directory may not be the current directory or its parent (vlt replaces it as a whole)");
  }
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(target_, ec);
  if (fs::exists(status)) {
    if (!fs::is_directory(status)) {
      throw InputError(target_.string() + ": the output path exists and is not a directory");
    }
    const std::set<std::string> listed = NamesInMarker(target_ / kOutputMarker);
    for (const fs::directory_entry& e : fs::directory_iterator(target_, ec)) {
      const std::string name = e.path().filename().string();
      if (name == kOutputMarker || listed.count(name)) continue;
      if (!KnownOutputNames().count(name)) {
        throw InputError(target_.string() + ": the output directory holds '" + name +
                         "', which vlt did not write; vlt replaces its output directory as a whole, so "
                         "choose another directory (-o) or empty this one");
      }
    }
    if (ec) throw InputError(target_.string() + ": cannot read the output directory: " + ec.message());
  }
  // The directory the staging directory goes into must exist (or be creatable) and be writable.
  fs::path parent = target_.parent_path();
  if (parent.empty()) parent = ".";
  fs::path existing = parent;
  while (!existing.empty() && !fs::exists(existing, ec)) existing = existing.parent_path();
  if (existing.empty()) existing = ".";
  if (!fs::is_directory(existing, ec)) {
    throw InputError(target_.string() + ": '" + existing.string() + "' is not a directory");
  }
  if (::access(existing.c_str(), W_OK | X_OK) != 0) {
    throw InputError(target_.string() + ": cannot write into '" + existing.string() + "'");
  }
  parent_ = parent;
}

OutputDirectory::~OutputDirectory() {
  if (!staging_.empty()) {
    g_staging_active = 0;
    RemoveQuietly(staging_);
  }
}

OutputFile::OutputFile(std::string file_name, std::string content)
    : name(std::move(file_name)), write([text = std::move(content)](OutputText& out) { out.Write(text); }) {}

OutputFile::OutputFile(std::string file_name, std::function<void(OutputText&)> writer)
    : name(std::move(file_name)), write(std::move(writer)) {}

namespace {

// A staging file, written through a 1 MiB stdio buffer; a write error is reported once at the end.
class FileText final : public OutputText {
 public:
  explicit FileText(const fs::path& path) : file_(std::fopen(path.c_str(), "wb")) {
    if (file_ != nullptr) std::setvbuf(file_, nullptr, _IOFBF, std::size_t{1} << 20);
  }
  ~FileText() override {
    if (file_ != nullptr) std::fclose(file_);
  }
  FileText(const FileText&) = delete;
  FileText& operator=(const FileText&) = delete;
  void Write(std::string_view text) override {
    if (file_ != nullptr && !text.empty()) std::fwrite(text.data(), 1, text.size(), file_);
  }
  // Flushes and closes; false on any error since opening.
  bool Close() {
    if (file_ == nullptr) return false;
    const bool ok = std::fflush(file_) == 0 && std::ferror(file_) == 0;
    const bool closed = std::fclose(file_) == 0;
    file_ = nullptr;
    return ok && closed;
  }

 private:
  std::FILE* file_;
};

}  // namespace

std::vector<OutputFile> AsOutputFiles(const std::vector<std::pair<std::string, std::string>>& files) {
  std::vector<OutputFile> all;
  all.reserve(files.size());
  for (const auto& [name, content] : files) all.emplace_back(name, content);
  return all;
}

namespace {

// Swaps two paths in one step with renameat2(RENAME_EXCHANGE) where the C library has it (glibc
// 2.28+: VLT_HAVE_RENAMEAT2, checked by CMake) and the file system supports it. false: the caller
// moves the old set aside instead. VLT_NO_RENAME_EXCHANGE in the environment forces that fallback
// (the test of it, tests/cli.cmake cli_run_twice_without_exchange; docs/cli.md "Outputs").
bool ExchangePaths(const fs::path& a, const fs::path& b) {
#if VLT_HAVE_RENAMEAT2
  if (std::getenv("VLT_NO_RENAME_EXCHANGE") != nullptr) return false;
  return ::renameat2(AT_FDCWD, a.c_str(), AT_FDCWD, b.c_str(), RENAME_EXCHANGE) == 0;
#else
  (void)a;
  (void)b;
  return false;
#endif
}

}  // namespace

void OutputDirectory::Commit(const std::vector<OutputFile>& files) {
  // Under MPI every rank computed the same results; they agree that none failed, and rank 0
  // alone writes (docs/mpi.md). Without MPI, Agree does nothing.
  ranks::Agree();
  if (!ranks::IsRoot()) return;
  std::error_code ec;
  fs::create_directories(parent_, ec);
  if (ec) throw InputError(target_.string() + ": cannot create '" + parent_.string() + "': " + ec.message());
  const std::string name = StagingStem(target_.filename().string());
  // Staging directories of earlier runs that were killed (SIGKILL, power loss) are ours by name;
  // a live run's is not (two runs into one directory: the last to commit wins, neither fails).
  std::vector<fs::path> stale;
  for (const fs::directory_entry& e : fs::directory_iterator(parent_, ec)) {
    if (LeftByADeadRun(e.path().filename().string(), name)) stale.push_back(e.path());
  }
  for (const fs::path& p : stale) RemoveQuietly(p);
  const std::string pid = std::to_string(::getpid());
  staging_ = parent_ / ("." + name + ".vlt-new-" + pid);
  RemoveQuietly(staging_);
  // Prepare the signal handler's list before anything exists on disk.
  std::vector<OutputFile> all = files;
  std::string marker = std::string("written by vlt ") + VLT_VERSION +
                       "; vlt replaces this directory as a whole on its next run into it. Files:\n";
  for (const OutputFile& f : files) marker += f.name + "\n";
  all.emplace_back(kOutputMarker, marker);
  g_staging_active = 0;
  int count = 0;
  bool registered = CopyPath(g_staging_dir, staging_) && all.size() <= static_cast<std::size_t>(kMaxStaged);
  for (std::size_t i = 0; registered && i < all.size(); ++i) {
    registered = CopyPath(g_staged_files[count++], staging_ / all[i].name);
  }
  g_staged_count = registered ? count : 0;
  g_staging_active = registered ? 1 : 0;

  if (!fs::create_directory(staging_, ec) || ec) {
    throw InputError(target_.string() + ": cannot create the staging directory '" + staging_.string() +
                     "': " + (ec ? ec.message() : std::string("it exists")));
  }
  for (const OutputFile& file : all) {
    if (file.name.find('/') != std::string::npos) {
      throw InputError(file.name + ": an output file name may not contain '/'");
    }
    // A name made of a user's (simulated_<station>.csv) can pass what a file system takes: say so,
    // not "disk full?" when the write fails.
    if (file.name.size() > 255) {
      throw InputError(target_.string() + ": output file '" + file.name +
                       "': " + std::to_string(file.name.size()) +
                       " bytes, longer than a file name may be (255): shorten the name it is made of");
    }
    FileText out(staging_ / file.name);
    file.write(out);
    if (!out.Close())
      throw InputError((target_ / file.name).string() + ": cannot write the output file (disk full?)");
  }
  // Swap in.
  const bool exists = fs::exists(fs::symlink_status(target_, ec));
  if (exists) {
    if (ExchangePaths(staging_, target_)) {
      // staging_ now holds the old set.
      g_staging_active = 0;
      RemoveQuietly(staging_);
      staging_.clear();
      return;
    }
    // No exchange on this file system: move the old set aside, then the new one in.
    const fs::path old = parent_ / ("." + name + ".vlt-old-" + pid);
    fs::rename(target_, old, ec);
    if (ec) throw InputError(target_.string() + ": cannot replace the output directory: " + ec.message());
    fs::rename(staging_, target_, ec);
    if (ec) {
      std::error_code ignore;
      fs::rename(old, target_, ignore);  // put the old set back
      throw InputError(target_.string() + ": cannot replace the output directory: " + ec.message());
    }
    g_staging_active = 0;
    staging_.clear();
    RemoveQuietly(old);
    return;
  }
  fs::rename(staging_, target_, ec);
  if (ec) throw InputError(target_.string() + ": cannot create the output directory: " + ec.message());
  g_staging_active = 0;
  staging_.clear();
}

}  // namespace vlt
