// libFuzzer harness: a custom-model job file (vlt/custom_job.h) through its parser and the GUM
// (vlt::RunCustomJob without Monte Carlo). Every input must end in a result or an InputError /
// NumericalError (exit 2 on the command line); a crash, undefined behaviour or a non-finite
// number in a result is a finding (the harness aborts on one). docs/testing.md "Fuzzing".
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string_view>

#include "vlt/custom_job.h"
#include "vlt/error.h"
#include "vlt/results.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const vlt::CustomJob job =
        vlt::ParseCustomJob(text, "fuzz.toml", std::filesystem::path("/nonexistent-vlt-fuzz"));
    vlt::RunOptions options;
    options.monte_carlo = false;
    options.threads = 1;
    const vlt::CustomResults results = vlt::RunCustomJob(job, options);
    for (const vlt::CustomOutputResult& o : results.outputs) {
      if (!std::isfinite(o.gum.estimate) || !std::isfinite(o.gum.u) || !std::isfinite(o.gum.U) ||
          !std::isfinite(o.gum.second_order_variance)) {
        std::abort();
      }
      if (o.conformity && o.conformity->probability_gum && !std::isfinite(*o.conformity->probability_gum))
        std::abort();
    }
    (void)vlt::ResultFiles(results);  // the writers too
  } catch (const vlt::InputError&) {
  } catch (const vlt::NumericalError&) {}
  return 0;
}
