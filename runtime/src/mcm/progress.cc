// mcm/progress.cc — see progress.h.
#include "mcm/progress.h"

#include <cstdio>
#include <utility>

#include <unistd.h>

namespace vlt::mcm_internal {

ProgressBar::ProgressBar(std::string label, bool quiet)
    : label_(std::move(label)),
      enabled_(!quiet && isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

ProgressBar::~ProgressBar() { Finish(); }

void ProgressBar::Update(std::int64_t done, std::int64_t total, const std::string& status) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  if (elapsed < 1.0) return;
  if (drawn_ && std::chrono::duration<double>(now - last_draw_).count() < 0.2) return;
  last_draw_ = now;
  char line[256];
  if (total > 0) {
    constexpr int kWidth = 24;
    const double fraction = static_cast<double>(done) / static_cast<double>(total);
    const int filled = static_cast<int>(fraction * kWidth + 0.5);
    char bar[kWidth + 1];
    for (int i = 0; i < kWidth; ++i) bar[i] = i < filled ? '#' : '.';
    bar[kWidth] = '\0';
    std::snprintf(line, sizeof line, "%s [%s] %lld/%lld trials  %s", label_.c_str(), bar,
                  static_cast<long long>(done), static_cast<long long>(total), status.c_str());
  } else {
    std::snprintf(line, sizeof line, "%s %lld trials  %s", label_.c_str(), static_cast<long long>(done),
                  status.c_str());
  }
  std::fprintf(stderr, "\r%-100s", line);
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::Finish() {
  if (drawn_) {
    std::fputc('\n', stderr);
    std::fflush(stderr);
    drawn_ = false;
  }
}

}  // namespace vlt::mcm_internal
