// base/toml_text.h — a TOML basic string for any text (internal): the files vlt writes for
// users to read back (calibration.toml, simulated_calibration.toml) must parse whatever names and
// free text they carry.
#pragma once

#include <cstdio>
#include <string>

namespace vlt::base_internal {

// "..." with \" \\ \n \t escaped and every other control character as \uXXXX (TOML 1.0 2.5).
inline std::string TomlQuoted(const std::string& text) {
  std::string out = "\"";
  for (const char ch : text) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += ch;
    } else if (c == '\n') {
      out += "\\n";
    } else if (c == '\t') {
      out += "\\t";
    } else if (c < 0x20 || c == 0x7f) {
      char buffer[8];
      std::snprintf(buffer, sizeof buffer, "\\u%04x", c);
      out += buffer;
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

}  // namespace vlt::base_internal
