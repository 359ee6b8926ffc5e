// libFuzzer harness: the files of `vlt network`, `vlt test` and `vlt calibrate` (issue 32) — each
// input is written to a file and read by every one of their readers as the command line reads it:
// a network file (vlt::LoadNetworkJob, whose offline planning and time checks run inside it), a test
// layout and a test job (LoadTestLayout, LoadTestJob), a calibration job (LoadCalibrationJob) and
// a calibration file (LoadCalibrationFile). `vlt plan`'s [optimize] is the job reader's (fuzz_job).
// Every input must end in a value or an InputError / NumericalError (exit 2 on the command line); a
// crash, undefined behaviour, a hang (libFuzzer -timeout) or another exception is a finding.
// Files the input names (CSV readings, layouts) are looked up beside it, in a directory of this
// process that holds copies of the files of the directories in VLT_FUZZ_DATA (colon-separated:
// scripts/test-fuzz.sh gives the examples' network and calibration folders, so that a mutated
// example still finds its readings and gets past them). docs/testing.md "Fuzzing".
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <string>
#include <system_error>

#include <unistd.h>

#include "vlt/calibration.h"
#include "vlt/error.h"
#include "vlt/network.h"

namespace {

// <temp>/vlt-fuzz-files-<pid>/input.toml, written afresh for every input.
const std::string& InputPath() {
  static const std::string path = [] {
    std::error_code ec;
    const std::filesystem::path dir =
        std::filesystem::temp_directory_path(ec) / ("vlt-fuzz-files-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir, ec);
    const char* data = std::getenv("VLT_FUZZ_DATA");
    std::string list = data ? data : "";
    for (std::size_t begin = 0; begin < list.size();) {
      const std::size_t end = std::min(list.find(':', begin), list.size());
      for (const auto& entry : std::filesystem::directory_iterator(list.substr(begin, end - begin), ec)) {
        if (entry.is_regular_file(ec) && entry.file_size(ec) <= (1u << 20)) {
          std::filesystem::copy_file(entry.path(), dir / entry.path().filename(),
                                     std::filesystem::copy_options::skip_existing, ec);
        }
      }
      begin = end + 1;
    }
    return (dir / "input.toml").string();
  }();
  return path;
}

template <class Read>
void Try(const Read& read) {
  try {
    read();
  } catch (const vlt::InputError&) {
  } catch (const vlt::NumericalError&) {}
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = InputPath();
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  Try([&] { (void)vlt::LoadNetworkJob(path); });
  Try([&] { (void)vlt::LoadTestLayout(path); });
  Try([&] { (void)vlt::LoadTestJob(path); });
  Try([&] { (void)vlt::LoadCalibrationJob(path); });
  Try([&] { (void)vlt::LoadCalibrationFile(path); });
  return 0;
}
