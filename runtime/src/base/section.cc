// base/section.cc — reading TOML tables strictly (base/section.h): the Section that rejects unknown
// keys, typed getters with unit strings, and the uncertain-input table shared by every section.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <toml++/toml.h>

#include "base/section.h"
#include "vlt/distributions.h"
#include "vlt/error.h"
#include "vlt/input_file.h"
#include "vlt/units.h"

namespace vlt {

Dimension DimensionOfQuantity(std::string_view quantity, const std::string& where) {
  for (Dimension d :
       {Dimension::kLength, Dimension::kAngle, Dimension::kRatio, Dimension::kTemperature,
        Dimension::kTemperatureDifference, Dimension::kPressure, Dimension::kHumidity, Dimension::kFraction,
        Dimension::kPerKelvin, Dimension::kDimensionless, Dimension::kTime}) {
    if (DimensionName(d) == quantity) return d;
  }
  throw InputError(where + ": the model declares an unknown quantity kind '" + std::string(quantity) + "'");
}

namespace base_internal {

std::string Section::Where(std::string_view key) const {
  if (path_.empty()) return file_ + ": " + std::string(key);
  return file_ + ": " + path_ + "." + std::string(key);
}

std::string Section::WhereSelf() const { return file_ + ": " + (path_.empty() ? "(top)" : path_); }

const toml::node* Section::Get(std::string_view key) {
  used_.insert(std::string(key));
  return table_->get(key);
}

const toml::node& Section::Require(std::string_view key) {
  const toml::node* node = Get(key);
  if (!node) throw InputError(Where(key) + ": required key is missing");
  return *node;
}

void Section::Finish() const {
  for (auto&& [key, node] : *table_) {
    (void)node;
    if (!used_.count(std::string(key.str()))) {
      throw InputError(Where(key.str()) + ": unknown key" +
                       (allowed_hint_.empty() ? "" : " (expected one of: " + allowed_hint_ + ")"));
    }
  }
}

Section Section::Sub(std::string_view key, bool required) {
  const toml::node* node = required ? &Require(key) : Get(key);
  std::string sub_path = path_.empty() ? std::string(key) : path_ + "." + std::string(key);
  if (!node) return Section(file_, sub_path);
  if (!node->is_table()) throw InputError(Where(key) + ": expected a table");
  return Section(*node->as_table(), file_, sub_path);
}

std::string AsString(const toml::node& node, const std::string& where) {
  if (!node.is_string()) throw InputError(where + ": expected a string");
  return std::string(node.value<std::string>().value());
}

bool AsBool(const toml::node& node, const std::string& where) {
  if (!node.is_boolean()) throw InputError(where + ": expected true or false");
  return *node.value<bool>();
}

std::int64_t AsInteger(const toml::node& node, const std::string& where) {
  if (node.is_integer()) return *node.value<std::int64_t>();
  if (node.is_floating_point()) {
    double v = *node.value<double>();
    if (std::isfinite(v) && v == std::floor(v) && std::abs(v) < 9e15) {
      return static_cast<std::int64_t>(v);
    }
  }
  throw InputError(where + ": expected an integer");
}

double AsNumber(const toml::node& node, const std::string& where) {
  if (!node.is_number()) throw InputError(where + ": expected a number");
  double v = *node.value<double>();
  if (!std::isfinite(v)) throw InputError(where + ": not a finite number");
  return v;
}

double AsQuantity(const toml::node& node, Dimension dimension, const std::string& where) {
  if (node.is_string()) return ParseQuantity(*node.value<std::string>(), dimension, where);
  if (node.is_number()) return AsNumber(node, where);
  throw InputError(where + ": expected a " + std::string(DimensionName(dimension)) +
                   " (a string with a unit, e.g. \"12 um\", or a number in " +
                   std::string(SiUnit(dimension)) + ")");
}

// The distribution name is parsed by the Monte Carlo engine's parser (vlt/distributions.h) and
// stored in its canonical spelling; the Distribution constructor checks the shape parameter.
void CheckDistribution(UncertainInput& input, const std::string& where_distribution,
                       const std::string& where_shape) {
  DistributionKind kind = ParseDistribution(input.distribution, where_distribution);
  input.distribution = std::string(DistributionName(kind));
  if (!HasShape(kind) && input.shape != 0.0) {
    throw InputError(where_shape + ": distribution '" + input.distribution + "' has no shape parameter");
  }
  (void)Distribution(kind, input.estimate, input.u, input.shape, where_shape);
}

void CheckUncertainty(double u, const std::string& where) {
  if (!std::isfinite(u)) throw InputError(where + ": uncertainty is not finite");
  if (u < 0.0) throw InputError(where + ": negative uncertainty");
  if (u > kMaxMagnitude)
    throw InputError(where + ": uncertainty beyond what vlt computes with (at most 1e12 in SI units)");
}

// An uncertain input: either a table {estimate, u, distribution, shape} (omitted keys keep the
// defaults in `input`) or a bare quantity (the estimate; u keeps its default).
void ReadUncertain(Section& parent, std::string_view key, Dimension value_dim, Dimension u_dim,
                   UncertainInput& input) {
  const toml::node* node = parent.Get(key);
  if (!node) return;
  // The units the user typed, to show the values back in them (UncertainInput::display_*).
  auto typed = [](const toml::node& n, double si, Dimension dim) {
    if (!n.is_string()) return std::string();
    const std::string unit = TypedUnit(*n.value<std::string>());
    return unit.empty() ? std::string() : FormatQuantity(si, dim, unit, 8);
  };
  if (!node->is_table()) {
    input.estimate = AsQuantity(*node, value_dim, parent.Where(key));
    input.display_estimate = typed(*node, input.estimate, value_dim);
    if (std::abs(input.estimate) > kMaxMagnitude) {
      throw InputError(parent.Where(key) + ": beyond what vlt computes with (at most 1e12 in SI units)");
    }
    return;
  }
  Section s = parent.Sub(key, false);
  s.set_hint("estimate, u, distribution, shape");
  if (const toml::node* n = s.Get("estimate")) {
    input.estimate = AsQuantity(*n, value_dim, s.Where("estimate"));
    input.display_estimate = typed(*n, input.estimate, value_dim);
  }
  if (std::abs(input.estimate) > kMaxMagnitude) {
    throw InputError(s.Where("estimate") + ": beyond what vlt computes with (at most 1e12 in SI units)");
  }
  if (const toml::node* n = s.Get("u")) {
    input.u = AsQuantity(*n, u_dim, s.Where("u"));
    CheckUncertainty(input.u, s.Where("u"));
    input.display_u = typed(*n, input.u, u_dim);
  }
  if (const toml::node* n = s.Get("distribution")) input.distribution = AsString(*n, s.Where("distribution"));
  if (const toml::node* n = s.Get("shape")) input.shape = AsNumber(*n, s.Where("shape"));
  CheckDistribution(input, s.Where("distribution"), s.Where("shape"));
  s.Finish();
}

UncertainInput MakeInput(std::string name, std::string group, Dimension dim, double estimate, double u) {
  UncertainInput input;
  input.name = std::move(name);
  input.unit = std::string(SiUnit(dim));
  input.group = std::move(group);
  input.estimate = estimate;
  input.u = u;
  return input;
}

namespace {

// The most parts of a dotted key or table name ([a.b.c] has 3). vlt's own keys have at most 4;
// Debian's toml++ 3.3.0 recurses once per part and overflows the stack at some 40 000 of them.
constexpr int kMaxKeyParts = 64;

// What vlt checks in a TOML text before the parser sees it:
// - TOML allows non-ASCII bytes only inside strings and comments. Debian's toml++ 3.3.0 has
//   undefined behaviour on some of them elsewhere (a bare "5 µm" or "20 °C"), so vlt refuses them
//   itself, with the fix in the message.
// - A dotted key of more than kMaxKeyParts parts, which would crash the parser: the dots between
//   bare or quoted parts are counted until anything but a part, a dot or a blank (a number's
//   decimal point counts one, a key's parts and a number are never joined).
void CheckTextOutsideStrings(std::string_view text, const std::string& file) {
  int line = 1, column = 0;
  std::size_t i = 0;
  int dots = 0;  // dots joining the parts since the last character that is none of them
  auto where = [&] { return file + ": line " + std::to_string(line) + ", column " + std::to_string(column + 1); };
  auto part_or_blank = [](unsigned char c) {
    return std::isalnum(c) != 0 || c == '_' || c == '-' || c == '+' || c == ' ' || c == '\t' || c == ':';
  };
  auto starts = [&](std::string_view token) { return text.substr(i, token.size()) == token; };
  auto advance = [&](std::size_t n) {
    for (std::size_t k = 0; k < n && i < text.size(); ++k, ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 0;
      } else {
        ++column;
      }
    }
  };
  while (i < text.size()) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c == '#') {
      while (i < text.size() && text[i] != '\n') advance(1);
    } else if (starts("\"\"\"") || starts("'''")) {
      const std::string_view close = text.substr(i, 3);
      advance(3);
      while (i < text.size() && !starts(close)) advance(text[i] == '\\' && close[0] == '"' ? 2 : 1);
      advance(3);
    } else if (c == '"' || c == '\'') {
      advance(1);
      while (i < text.size() && text[i] != static_cast<char>(c) && text[i] != '\n') {
        advance(text[i] == '\\' && c == '"' ? 2 : 1);
      }
      advance(1);
    } else if (c >= 0x80) {
      throw InputError(where() + ": a non-ASCII character outside a quoted string; values with units go in quotes, "
                             "e.g. \"5 um\", \"20 degC\"");
    } else if (c == '.') {
      if (++dots >= kMaxKeyParts) {
        throw InputError(where() + ": a dotted key or table name of more than " + std::to_string(kMaxKeyParts) +
                         " parts");
      }
      advance(1);
    } else {
      if (!part_or_blank(c)) dots = 0;
      advance(1);
    }
  }
}

}  // namespace

toml::table ParseToml(std::string_view text, const std::string& file) {
  // A UTF-8 byte order mark at the start (editors on Windows write one), as the CSV reader allows.
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
  CheckTextOutsideStrings(text, file);
  try {
    return toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    std::string desc(e.description());
    std::replace(desc.begin(), desc.end(), '\n', ' ');
    throw InputError(file + ": line " + std::to_string(e.source().begin.line) + ", column " +
                     std::to_string(e.source().begin.column) + ": TOML syntax error: " + desc);
  }
}

std::string ReadTextFile(const std::string& path, const std::string& what) {
  return ReadInputFile(path, path, "cannot read " + what);
}

std::filesystem::path BaseDirectory(const std::string& path) {
  std::filesystem::path base = std::filesystem::path(path).parent_path();
  return base.empty() ? std::filesystem::path(".") : base;
}

namespace {

// Does UTF-8 text hold a control or layout character: C0 and DEL, C1 (U+0080..U+009F: NEL is a
// line break, CSI an escape for terminals), the line and paragraph separators U+2028/U+2029, the
// bidirectional marks, embeddings, overrides and isolates (U+061C, U+200E/F, U+202A..U+202E,
// U+2066..U+2069), which reorder what a reader sees, and the invisible U+200B, U+2060..U+2064 and
// U+FEFF, which make two names that look alike differ?
bool HasControlCharacter(std::string_view text) {
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto b = [&](std::size_t k) { return k < text.size() ? static_cast<unsigned char>(text[k]) : 0u; };
    const unsigned c = b(i);
    if (c < 0x20 || c == 0x7f) return true;
    if (c == 0xc2 && b(i + 1) >= 0x80 && b(i + 1) <= 0x9f) return true;  // C1
    if (c == 0xe2 && b(i + 1) == 0x80) {
      const unsigned d = b(i + 2);
      if (d == 0x8e || d == 0x8f || d == 0xa8 || d == 0xa9 || (d >= 0xaa && d <= 0xae)) return true;
    }
    if (c == 0xe2 && b(i + 1) == 0x81 && b(i + 2) >= 0xa6 && b(i + 2) <= 0xa9) return true;
    if (c == 0xe2 && b(i + 1) == 0x80 && b(i + 2) == 0x8b) return true;                      // U+200B
    if (c == 0xe2 && b(i + 1) == 0x81 && b(i + 2) >= 0xa0 && b(i + 2) <= 0xa4) return true;  // U+2060..4
    if (c == 0xd8 && b(i + 1) == 0x9c) return true;                                          // U+061C
    if (c == 0xef && b(i + 1) == 0xbb && b(i + 2) == 0xbf) return true;                      // U+FEFF
  }
  return false;
}

}  // namespace

void CheckName(std::string_view name, const std::string& where, std::string_view what) {
  if (name.empty()) throw InputError(where + ": empty " + std::string(what) + " name");
  if (HasControlCharacter(name)) {
    throw InputError(where + ": the " + std::string(what) +
                     " name holds a control or layout character (a line break, tab, escape or "
                     "bidirectional mark): a name is one line of visible text");
  }
}

// A one-line text of the record: it is printed in headers and filed, so no control or layout
// characters (a line break, an escape sequence or a bidirectional override would forge, hide or
// reorder a line of the report).
std::string RecordText(Section& s, std::string_view key) {
  const toml::node* n = s.Get(key);
  if (n == nullptr) return "";
  std::string text = AsString(*n, s.Where(key));
  if (HasControlCharacter(text)) {
    throw InputError(s.Where(key) +
                     ": a control character in the text (one line of printable text expected)");
  }
  return text;
}

namespace {

void ReadRecord(Section& meta, JobRecord& record) {
  record.customer = RecordText(meta, "customer");
  record.operator_name = RecordText(meta, "operator");
  record.place = RecordText(meta, "place");
  record.conditions = RecordText(meta, "conditions");
  Section instrument = meta.Sub("instrument", false);
  if (!instrument.exists()) return;
  instrument.set_hint("make, model, serial");
  record.instrument.make = RecordText(instrument, "make");
  record.instrument.model = RecordText(instrument, "model");
  record.instrument.serial = RecordText(instrument, "serial");
  instrument.Finish();
}

}  // namespace

void ReadJobMeta(Section& top, std::string& name, std::string* description, const std::string& default_name,
                 JobRecord* record) {
  name = default_name;
  Section meta = top.Sub("job", false);
  if (!meta.exists()) return;
  meta.set_hint(record ? "name, description, customer, operator, place, conditions, instrument"
                       : "name, description");
  if (record) ReadRecord(meta, *record);
  if (const toml::node* n = meta.Get("name")) name = AsString(*n, meta.Where("name"));
  if (const toml::node* n = meta.Get("description")) {
    const std::string text = AsString(*n, meta.Where("description"));
    if (description) *description = text;
  }
  CheckName(name, meta.Where("name"), "job");
  meta.Finish();
}

}  // namespace base_internal

std::string DescribeInstrument(const InstrumentIdentity& instrument) {
  std::string text = instrument.make;
  if (!instrument.model.empty()) text += (text.empty() ? "" : " ") + instrument.model;
  if (!instrument.serial.empty()) text += (text.empty() ? "serial " : ", serial ") + instrument.serial;
  return text;
}

}  // namespace vlt
