// mcm/progress.h — a one-line progress bar on stderr for long computations (internal).
//
// Shown only when the computation has lasted more than ~1 s, stderr is a terminal (isatty) and
// the caller did not ask for quiet; redrawn at most 5 times a second with '\r'; Finish() ends
// the line. Never writes to stdout, never writes when stderr is a file or a pipe.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace vlt::mcm_internal {

class ProgressBar {
 public:
  // `label` starts the line, e.g. "Monte Carlo".
  ProgressBar(std::string label, bool quiet);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  // `done` of `total` units (total 0 = unknown, e.g. the adaptive procedure), and a short
  // status text (e.g. the current standard error).
  void Update(std::int64_t done, std::int64_t total, const std::string& status);
  // Ends the line if anything was drawn. Called by the destructor too.
  void Finish();

  bool enabled() const { return enabled_; }

 private:
  std::string label_;
  bool enabled_ = false;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace vlt::mcm_internal
