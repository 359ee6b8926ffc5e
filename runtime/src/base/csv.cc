#include "base/csv.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <functional>
#include <iterator>
#include <stdexcept>
#include <string_view>
#include <unordered_set>
#include <utility>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "base/decimal.h"
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

namespace {

// The line of `text` that starts at `pos`: a line ends at LF, CRLF or a lone CR (old spreadsheet
// exports on macOS); `next` is where the following line starts, `last` whether this one ends the text.
struct Line {
  std::string_view text;
  std::size_t next = 0;
  bool last = false;
};

Line LineAt(std::string_view text, std::size_t pos) {
  // The first LF or CR: memchr for the LF, then for a CR before it (find_first_of with the set
  // "\r\n" calls memchr on the set for every byte: a fifth of a scan's loading), within windows
  // that double from 512 bytes (a file of lone CRs has no LF: a search for it to the end of the
  // text would make each line cost the rest of the file).
  std::size_t end = text.size();
  for (std::size_t from = pos, width = 512; from < text.size(); from += width, width *= 2) {
    const std::string_view window = text.substr(from, width);
    const std::size_t lf = window.find('\n');
    const std::size_t at = std::min(lf, window.substr(0, lf).find('\r'));
    if (at != std::string_view::npos) {
      end = from + at;
      break;
    }
  }
  Line line{text.substr(pos, end - pos), end + 1, end >= text.size()};
  if (end < text.size() && text[end] == '\r' && line.next < text.size() && text[line.next] == '\n') ++line.next;
  return line;
}

bool Skipped(std::string_view line) {
  const std::string_view trimmed = TrimView(line);
  return trimmed.empty() || trimmed[0] == '#';
}

// The fields of a row of `table` (its separator and columns), or the error of the line.
std::vector<std::string> RowFields(const CsvTable& table, bool headerless, std::string_view line,
                                   const LinePlace& where) {
  std::vector<std::string> fields = table.delimiter == ' '
                                        ? SplitOnBlanks(line, where, table.header.size())
                                        : SplitLine(line, where, table.delimiter, table.header.size());
  if (table.delimiter != ',') {
    for (std::string& field : fields) DecimalCommaToPoint(field);
  }
  if (fields.size() != table.header.size()) {
    throw InputError(where.str() + ": " + std::to_string(fields.size()) + " fields, " +
                     (headerless ? "the columns name " : "the header has ") +
                     std::to_string(table.header.size()) + " (separator '" + SeparatorName(table.delimiter) +
                     (headerless ? "', taken from the first row)" : "', taken from the header line)"));
  }
  return fields;
}

// Line ends in text[begin, end) as LineAt counts them (CRLF once).
int LinesIn(std::string_view text, std::size_t begin, std::size_t end) {
  if (begin >= end) return 0;
  int lines = static_cast<int>(std::count(text.begin() + begin, text.begin() + end, '\n'));
  const std::string_view piece = text.substr(0, end);
  for (std::size_t cr = piece.find('\r', begin); cr != std::string_view::npos; cr = piece.find('\r', cr + 1)) {
    if (cr + 1 >= text.size() || text[cr + 1] != '\n') ++lines;
  }
  return lines;
}

// Pieces of whole lines of about kPieceBytes from `begin`: each ends just after a LF (a text with
// lone CR line ends is one piece). Fixed by the text alone, never by the thread count.
constexpr std::size_t kPieceBytes = std::size_t{1} << 18;

std::vector<std::size_t> PieceStarts(std::string_view text, std::size_t begin) {
  std::vector<std::size_t> starts = {begin};
  while (text.size() - starts.back() > kPieceBytes) {
    const std::size_t lf = text.find('\n', starts.back() + kPieceBytes - 1);
    if (lf == std::string_view::npos || lf + 1 >= text.size()) break;
    starts.push_back(lf + 1);
  }
  return starts;
}

}  // namespace

CsvPieces::CsvPieces(std::string_view text, const std::string& file, const std::vector<std::string>* columns)
    : text_(text), headerless_(columns != nullptr) {
  head_.file = file;
  // A NUL byte: not a text file (and a field with one would cut every message that quotes it).
  if (const std::size_t nul = text.find('\0'); nul != std::string_view::npos) {
    const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(nul), '\n');
    throw InputError(file + ": line " + std::to_string(line) + ": a NUL byte (not a text file?)");
  }
  if (headerless_) head_.header = *columns;
  // Skip a UTF-8 byte order mark (spreadsheets write one).
  std::size_t pos = text.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0;
  int line_number = 1;
  // The first line that is not blank or a comment sets the separator and, in a file with a header,
  // is the header.
  for (bool found = false; !found;) {
    const Line line = LineAt(text, pos);
    if (!Skipped(line.text)) {
      found = true;
      head_.delimiter = DetectDelimiter(line.text, !headerless_);
      if (headerless_) break;  // this line is the first row
      const LinePlace where{file, line_number};
      std::vector<std::string> fields = head_.delimiter == ' ' ? SplitOnBlanks(line.text, where)
                                                               : SplitLine(line.text, where, head_.delimiter);
      // The first repeated name in the header's order, by a set (a header of 10^6 columns is
      // read in a second, not compared pair by pair).
      std::unordered_set<std::string_view> seen;
      for (const std::string& name : fields) {
        if (name.empty()) throw InputError(where.str() + ": empty column name in the header");
        if (!seen.insert(name).second) throw InputError(where.str() + ": column '" + name + "' appears twice");
      }
      head_.header = std::move(fields);
      head_.header_line = line_number;
    }
    if (line.last) {
      pos = text.size() + 1;  // no rows
      break;
    }
    ++line_number;
    pos = line.next;
  }
  if (head_.header.empty()) throw InputError(file + ": empty CSV file (no header line)");
  if (pos <= text.size()) starts_ = PieceStarts(text, pos);
  first_lines_.assign(starts_.size(), line_number);
}

std::size_t CsvPieces::End(std::size_t piece) const {
  return piece + 1 < starts_.size() ? starts_[piece + 1] : text_.size();
}

void CsvPieces::Count(const RunTasks& run) {
  std::vector<int> lines(starts_.size());
  rows_.assign(starts_.size(), 0);
  run(starts_.size(), [&](std::size_t k) {
    lines[k] = LinesIn(text_, starts_[k], End(k));
    for (std::size_t pos = starts_[k]; pos < End(k);) {
      const Line line = LineAt(text_, pos);
      if (!Skipped(line.text)) ++rows_[k];
      if (line.last) break;
      pos = line.next;
    }
  });
  for (std::size_t k = 1; k < starts_.size(); ++k) first_lines_[k] = first_lines_[k - 1] + lines[k - 1];
}

std::size_t CsvPieces::rows() const {
  std::size_t all = 0;
  for (const std::size_t n : rows_) all += n;
  return all;
}

void CsvPieces::CheckHasRows() const {
  if (headerless_ && rows() == 0) throw InputError(head_.file + ": empty file (no rows)");
}

void CsvPieces::Read(std::size_t piece, const std::function<void(CsvRow&)>& take) const {
  // The pieces' first line numbers are known once every piece is counted.
  if (rows_.size() != starts_.size()) throw std::logic_error("CsvPieces::Read before Count");
  int line_number = first_lines_.at(piece);
  for (std::size_t pos = starts_[piece]; pos < End(piece);) {
    const Line line = LineAt(text_, pos);
    if (!Skipped(line.text)) {
      CsvRow row{line_number, RowFields(head_, headerless_, line.text, LinePlace{head_.file, line_number})};
      take(row);
    }
    if (line.last) break;
    ++line_number;
    pos = line.next;
  }
}

CsvTable ParseCsv(std::string_view text, const std::string& file, const std::vector<std::string>* columns) {
  return ParseCsv(text, file, columns, [](std::size_t count, const std::function<void(std::size_t)>& task) {
    for (std::size_t i = 0; i < count; ++i) task(i);
  });
}

CsvTable ParseCsv(std::string_view text, const std::string& file, const std::vector<std::string>* columns,
                  const RunTasks& run) {
  CsvPieces pieces(text, file, columns);
  pieces.Count(run);
  // The rows, piece by piece side by side (a scan's plan: 10^6 rows); a failure is the first
  // failing row of the file, as one pass would find it.
  std::vector<std::vector<CsvRow>> rows(pieces.size());
  run(pieces.size(), [&](std::size_t k) {
    rows[k].reserve(pieces.RowsIn(k));
    pieces.Read(k, [&](CsvRow& row) { rows[k].push_back(std::move(row)); });
  });
  CsvTable table = pieces.head();
  table.rows.reserve(pieces.rows());
  for (std::vector<CsvRow>& piece : rows) std::move(piece.begin(), piece.end(), std::back_inserter(table.rows));
  pieces.CheckHasRows();
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
  const auto [end, ec] = ParseDecimal(digits, v);
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
