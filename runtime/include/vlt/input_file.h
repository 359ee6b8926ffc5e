// vlt/input_file.h — how vlt reads a file a user names (docs/cli.md "Files"): a regular file only
// (a directory, a FIFO, a device or a socket is refused before anything waits on it), at most
// kMaxInputFileBytes, every filesystem error (a symbolic-link loop, a name too long, a missing or
// unreadable file) one InputError line naming the file and the reason — never an exception of
// another kind, never a read that does not end.
#pragma once

#include <cstdint>
#include <string>

namespace vlt {

// 1 GiB: far beyond any job, readings or calibration file (a 10^6-point plan is ~50 MB).
inline constexpr std::uint64_t kMaxInputFileBytes = std::uint64_t{1} << 30;

// Why `path` cannot be read as an input file ("no such file", "a FIFO, not a regular file",
// "Too many levels of symbolic links", "1.5 GiB: larger than vlt reads (1 GiB)"), or "" when it can.
std::string InputFileProblem(const std::string& path);

// The bytes of `path`. InputError "<label>: <what>: <reason>" when it cannot be read (label: how
// messages name the file, usually its path; what: "cannot read the job file").
std::string ReadInputFile(const std::string& path, const std::string& label, const std::string& what);

}  // namespace vlt
