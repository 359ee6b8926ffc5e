// libFuzzer harness: a job file through the parser and the GUM engine (vlt::RunJob without Monte
// Carlo). Besides crashes and undefined behaviour, a non-finite number in any result is a finding
// (vlt promises never to print NaN): the harness aborts on one. docs/testing.md "Fuzzing".
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string_view>

#include "vlt/error.h"
#include "vlt/job.h"
#include "vlt/results.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    vlt::Job job = vlt::ParseJob(text, "fuzz.toml", std::filesystem::path("/nonexistent-vlt-fuzz"));
    if (job.points.size() > 64 || job.map) return 0;  // keep each input fast
    vlt::RunOptions options;
    options.monte_carlo = false;
    options.threads = 1;
    const vlt::Results results = vlt::RunJob(job, options);
    for (const vlt::PointResult& p : results.points) {
      if (!p.gum.part.allFinite() || !p.gum.cov_part.allFinite() || !p.gum.U_part().allFinite()) std::abort();
    }
    for (const vlt::TaskResult& t : results.tasks) {
      if (!t.gum.value.allFinite() || !t.gum.covariance.allFinite()) std::abort();
    }
  } catch (const vlt::InputError&) {
  } catch (const vlt::NumericalError&) {}
  return 0;
}
