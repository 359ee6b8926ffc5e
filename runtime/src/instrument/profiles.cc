// instrument/profiles.cc — the built-in instrument profiles (vlt/calibration.h BuiltInProfiles;
// docs/profiles.md): the prior files `vlt prior` derived from the datasheet statements in
// profiles/*.toml, kept in profiles/priors/ and compiled in by runtime/CMakeLists.txt, so that a job
// says `[tracker] profile = "leica-at500"` on any machine, without a file beside it.
#include <string>
#include <utility>
#include <vector>

#include "vlt/calibration.h"

namespace vlt {

const std::vector<std::pair<std::string, std::string>>& BuiltInProfiles() {
  static const std::vector<std::pair<std::string, std::string>> kProfiles = {
#include "profiles.inc"
  };
  return kProfiles;
}

}  // namespace vlt
