// vlt/error.h — the two ways vlt refuses to produce a number.
#pragma once

#include <stdexcept>
#include <string>

namespace vlt {

// The user's input is wrong (job file, CSV, command-line value, spec). The message is one line
// that names the file, the key or line, and the problem; the command line exits with status 2
// and writes no output files.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The input is well-formed but the requested result does not exist or cannot be computed
// reliably: a point on the tracker's vertical axis, zero range, an inverse that does not
// converge. Also exit status 2: vlt never prints NaN instead.
class NumericalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace vlt
