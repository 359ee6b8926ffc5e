#include "base/csv.h"

#include <charconv>
#include <cmath>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "vlt/error.h"
#include "vlt/input_file.h"
#include "vlt/units.h"

namespace vlt {
namespace {

std::string_view TrimView(std::string_view s) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  return s.substr(b, e - b);
}

std::string Trim(std::string_view s) { return std::string(TrimView(s)); }

// "<file>: line N" of a message, put together only when there is one (a plan of 10^6 rows).
struct LinePlace {
  const std::string& file;
  int line;
  std::string str() const { return file + ": line " + std::to_string(line); }
};

// Splits one physical line into fields (`expected` of them, for the reservation). Quoted fields
// may not span lines (plan and readings files never need that, and it keeps line numbers exact).
std::vector<std::string> SplitLine(std::string_view line, const LinePlace& where, char delimiter,
                                   std::size_t expected = 0) {
  std::vector<std::string> fields;
  fields.reserve(expected);
  std::size_t i = 0;
  while (true) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    std::string field;
    if (i < line.size() && line[i] == '"') {
      ++i;
      bool closed = false;
      while (i < line.size()) {
        if (line[i] == '"') {
          if (i + 1 < line.size() && line[i + 1] == '"') {
            field += '"';
            i += 2;
            continue;
          }
          closed = true;
          ++i;
          break;
        }
        field += line[i++];
      }
      if (!closed) throw InputError(where.str() + ": unterminated quoted field");
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
      if (i < line.size() && line[i] != delimiter) {
        throw InputError(where.str() + ": unexpected text after a quoted field");
      }
    } else {
      std::size_t start = i;
      while (i < line.size() && line[i] != delimiter) ++i;
      field = Trim(line.substr(start, i - start));
    }
    fields.push_back(std::move(field));
    if (i >= line.size()) break;
    ++i;  // the delimiter
  }
  return fields;
}

// Splits a line of a file whose fields are separated by blanks (a run of spaces and tabs is one
// separator; a field with a blank is quoted): `name x y z` lists that tracker and CAD software
// export.
std::vector<std::string> SplitOnBlanks(std::string_view line, const LinePlace& where, std::size_t expected = 0) {
  std::vector<std::string> fields;
  fields.reserve(expected);
  std::size_t i = 0;
  auto blank = [&](std::size_t k) { return line[k] == ' ' || line[k] == '\t' || line[k] == '\r'; };
  while (true) {
    while (i < line.size() && blank(i)) ++i;
    if (i >= line.size()) break;
    std::string field;
    if (line[i] == '"') {
      std::size_t end = i + 1;
      while (end < line.size() && (line[end] != '"' || (end + 1 < line.size() && line[end + 1] == '"'))) {
        end += line[end] == '"' ? 2 : 1;
      }
      if (end >= line.size()) throw InputError(where.str() + ": unterminated quoted field");
      field = SplitLine(line.substr(i, end + 1 - i), where, ',')[0];
      i = end + 1;
      if (i < line.size() && !blank(i)) throw InputError(where.str() + ": unexpected text after a quoted field");
    } else {
      const std::size_t start = i;
      while (i < line.size() && !blank(i)) ++i;
      field = std::string(line.substr(start, i - start));
    }
    fields.push_back(std::move(field));
  }
  return fields;
}

// The separator of a file, from its header line: ';' (spreadsheets in locales with a decimal
// comma) or a tab when the header has one outside quotes, else ','. A file without a header line
// takes it from its first row, where neither ';', a tab nor ',' means blanks (' ').
char DetectDelimiter(std::string_view line, bool header) {
  bool quoted = false, tab = false, comma = false;
  for (char c : line) {
    if (c == '"') quoted = !quoted;
    if (quoted) continue;
    if (c == ';') return ';';
    tab = tab || c == '\t';
    comma = comma || c == ',';
  }
  if (tab) return '\t';
  return header || comma ? ',' : ' ';
}

std::string SeparatorName(char delimiter) {
  return delimiter == '\t' ? "tab" : delimiter == ' ' ? "blanks" : std::string(1, delimiter);
}

// With ';' or tab separators, "12,5", "-0,25e-3", "1,5 mm" are numbers with a decimal comma: the
// comma becomes a point. Anything else (a name such as "A,B") is left as it is.
void DecimalCommaToPoint(std::string& field) {
  std::size_t i = 0;
  if (i < field.size() && (field[i] == '+' || field[i] == '-')) ++i;
  const std::size_t int_start = i;
  while (i < field.size() && std::isdigit(static_cast<unsigned char>(field[i]))) ++i;
  if (i == int_start || i >= field.size() || field[i] != ',') return;
  const std::size_t comma = i++;
  const std::size_t frac_start = i;
  while (i < field.size() && std::isdigit(static_cast<unsigned char>(field[i]))) ++i;
  if (i == frac_start) return;
  if (i < field.size() && (field[i] == 'e' || field[i] == 'E')) {
    std::size_t j = i + 1;
    if (j < field.size() && (field[j] == '+' || field[j] == '-')) ++j;
    const std::size_t exp_start = j;
    while (j < field.size() && std::isdigit(static_cast<unsigned char>(field[j]))) ++j;
    if (j == exp_start) return;
    i = j;
  }
  if (i < field.size() && field[i] != ' ' && field[i] != '\t') return;  // a unit follows after a blank
  if (field.find(',', i) != std::string::npos) return;
  field[comma] = '.';
}

}  // namespace

namespace base_internal {

int CsvTable::Column(std::string_view name) const {
  for (std::size_t k = 0; k < header.size(); ++k) {
    if (header[k] == name) return static_cast<int>(k);
  }
  return -1;
}

std::string CsvTable::Where(const CsvRow& row) const { return file + ": line " + std::to_string(row.line); }

CsvTable ParseCsv(std::string_view text, const std::string& file, const std::vector<std::string>* columns) {
  CsvTable table;
  table.file = file;
  const bool headerless = columns != nullptr;
  bool delimiter_known = false;
  if (headerless) table.header = *columns;
  int line_number = 0;
  std::size_t pos = 0;
  // Skip a UTF-8 byte order mark (spreadsheets write one).
  if (text.substr(0, 3) == "\xEF\xBB\xBF") pos = 3;
  while (pos <= text.size()) {
    // A line ends at LF, CRLF or a lone CR (old spreadsheet exports on macOS).
    std::size_t end = text.find_first_of("\r\n", pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    ++line_number;
    pos = end + 1;
    if (end < text.size() && text[end] == '\r' && pos < text.size() && text[pos] == '\n') ++pos;
    const std::string_view trimmed = TrimView(line);
    if (trimmed.empty() || trimmed[0] == '#') {
      if (end >= text.size()) break;
      continue;
    }
    const LinePlace where{file, line_number};
    if (!delimiter_known) {
      table.delimiter = DetectDelimiter(line, !headerless);
      delimiter_known = true;
    }
    std::vector<std::string> fields = table.delimiter == ' '
                                          ? SplitOnBlanks(line, where, table.header.size())
                                          : SplitLine(line, where, table.delimiter, table.header.size());
    if (table.delimiter != ',' && !table.header.empty()) {
      for (std::string& field : fields) DecimalCommaToPoint(field);
    }
    if (table.header.empty()) {
      for (const std::string& name : fields) {
        if (name.empty()) throw InputError(where.str() + ": empty column name in the header");
        for (const std::string& other : table.header) {
          if (other == name) throw InputError(where.str() + ": column '" + name + "' appears twice");
        }
        table.header.push_back(name);
      }
      table.header_line = line_number;
    } else {
      if (fields.size() != table.header.size()) {
        throw InputError(where.str() + ": " + std::to_string(fields.size()) + " fields, " +
                         (headerless ? "the columns name " : "the header has ") +
                         std::to_string(table.header.size()) + " (separator '" +
                         SeparatorName(table.delimiter) +
                         (headerless ? "', taken from the first row)" : "', taken from the header line)"));
      }
      table.rows.push_back(CsvRow{line_number, std::move(fields)});
    }
    if (end >= text.size()) break;
  }
  if (table.header.empty()) throw InputError(file + ": empty CSV file (no header line)");
  if (headerless && table.rows.empty()) throw InputError(file + ": empty file (no rows)");
  return table;
}

CsvTable ReadCsvFile(const std::string& path, const std::string& label,
                     const std::vector<std::string>* columns) {
  return ParseCsv(ReadInputFile(path, label, "cannot read CSV file '" + path + "'"), label, columns);
}

double CsvQuantity(const std::string& field, std::optional<Dimension> dim, double unit_scale,
                   double unit_offset, const std::string& where, std::string_view suffix) {
  // The message's place is put together only when there is a message.
  auto at = [&] { return where + std::string(suffix); };
  if (field.empty()) throw InputError(at() + ": empty field");
  // A bare decimal number in the column's unit (docs/units.md: decimal literals only — no hex
  // floats, no inf/nan, which strtod would take); anything else must carry its own unit.
  std::string_view digits = field;
  if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
  double v = 0.0;
  const auto [end, ec] =
      std::from_chars(digits.data(), digits.data() + digits.size(), v, std::chars_format::general);
  if (ec == std::errc() && end == digits.data() + digits.size()) {
    if (!std::isfinite(v)) throw InputError(at() + ": '" + field + "' is not a finite number");
    return v * unit_scale + unit_offset;
  }
  if (ec == std::errc::result_out_of_range)
    throw InputError(at() + ": '" + field + "' is out of the range of finite numbers");
  if (!dim) throw InputError(at() + ": '" + field + "' is not a decimal number");
  return ParseQuantity(field, *dim, at());  // a field with its own unit
}

double CsvQuantity(const std::string& field, std::optional<Dimension> dim, double unit_scale,
                   double unit_offset, const std::string& where) {
  return CsvQuantity(field, dim, unit_scale, unit_offset, where, {});
}

}  // namespace base_internal
}  // namespace vlt
