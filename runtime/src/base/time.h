// base/time.h — times of readings and drift checks (docs/network.md N-12): a number of seconds
// (or a quantity "1.5 h"), a clock time "10:15:30.5", or a date and time
// "2026-11-26T10:15:30Z" / "2026-11-26 10:15:30" as tracker software writes them.
#pragma once

#include <string>
#include <string_view>

#include "vlt/units.h"

namespace vlt::base_internal {

// A time in seconds and its kind (vlt/units.h TimeKind): a date and time ("2026-11-26T10:15:30"),
// seconds since 1970-01-01 00:00 (UTC when the text gives a zone: "Z" or "+01:00"; without one the
// clock's own time); a clock time ("10:15:30"), seconds from midnight; or seconds from the file's
// own origin (a number, a quantity). The readers never mix kinds.
struct TimeValue {
  double seconds = 0.0;
  TimeKind kind = TimeKind::kSeconds;
};

// One field: a bare number in the column's unit (seconds x unit_scale), a quantity with its own
// time unit ("90 min"), a clock time or a date and time. InputError "<where>: ..." otherwise.
TimeValue ParseTime(std::string_view text, double unit_scale, const std::string& where);

}  // namespace vlt::base_internal
