// libFuzzer harness: the small parsers behind a job — CSV (vlt::base_internal::ParseCsv), quantities with units
// (vlt::ParseQuantity, every dimension) and map grids (ParseMapPlane / ParseMapBox). The input is
// split at the first two '\n' into three strings. docs/testing.md "Fuzzing".
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "base/csv.h"
#include "vlt/error.h"
#include "vlt/job.h"
#include "vlt/units.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::size_t a = text.find('\n');
  const std::size_t b = a == std::string_view::npos ? a : text.find('\n', a + 1);
  const std::string_view first = text.substr(0, a);
  const std::string_view second =
      a == std::string_view::npos ? std::string_view() : text.substr(a + 1, b - a - 1);
  const std::string_view third = b == std::string_view::npos ? std::string_view() : text.substr(b + 1);
  try {
    (void)vlt::base_internal::ParseCsv(text, "fuzz.csv");
  } catch (const vlt::InputError&) {}
  for (vlt::Dimension d :
       {vlt::Dimension::kLength, vlt::Dimension::kAngle, vlt::Dimension::kRatio, vlt::Dimension::kTemperature,
        vlt::Dimension::kTemperatureDifference, vlt::Dimension::kPressure, vlt::Dimension::kHumidity,
        vlt::Dimension::kFraction, vlt::Dimension::kPerKelvin}) {
    try {
      (void)vlt::ParseQuantity(first, d, "fuzz");
    } catch (const vlt::InputError&) {}
  }
  try {
    (void)vlt::ParseMapPlane(first, second, third, "fuzz").Nodes().size();
  } catch (const vlt::InputError&) {}
  try {
    (void)vlt::ParseMapBox(first, second, "fuzz").Nodes().size();
  } catch (const vlt::InputError&) {}
  return 0;
}
