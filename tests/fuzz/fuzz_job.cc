// libFuzzer harness: the job-file parser (vlt::ParseJob) on arbitrary bytes. Every input must end
// in a result or an InputError / NumericalError (exit 2 on the command line); anything else — an
// other exception, a crash, undefined behaviour (built with ASan + UBSan + float-cast-overflow) —
// is a finding. Relative CSV paths resolve into an empty directory. docs/testing.md "Fuzzing".
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>

#include "vlt/error.h"
#include "vlt/job.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    vlt::Job job = vlt::ParseJob(text, "fuzz.toml", std::filesystem::path("/nonexistent-vlt-fuzz"));
    (void)job;
  } catch (const vlt::InputError&) {
  } catch (const vlt::NumericalError&) {}
  return 0;
}
