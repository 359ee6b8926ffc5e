// base/csv.h — reading the small CSV files a job refers to (plan points, tracker readings), keeping
// the line number of every row so that an error names "<file>: line N: <problem>".
//
// Dialect (RFC 4180 subset): the first non-blank, non-comment line is the header and sets the
// separator: ';' or a tab when it has one (outside quotes), else ','. With ';' or tab, a field that
// is a number with a decimal comma ("12,5", "-0,25e-3", "1,5 mm") is read with a decimal point
// (spreadsheet exports in such locales). Fields may be enclosed in double quotes ("" is a quote
// inside); blanks around fields are ignored; lines that are blank or start with '#' are skipped;
// CRLF and CR line ends and a UTF-8 byte order mark are accepted.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "vlt/units.h"

namespace vlt::base_internal {

struct CsvRow {
  int line = 0;                     // 1-based line number in the file
  std::vector<std::string> fields;  // trimmed, unquoted
};

struct CsvTable {
  std::string file;                 // path as used in messages
  int header_line = 0;              // 0: no header line (the caller named the columns)
  char delimiter = ',';             // ',', ';', '\t' or ' ' (blanks; a file without a header line)
  std::vector<std::string> header;  // column names, trimmed
  std::vector<CsvRow> rows;         // every row has exactly header.size() fields

  // Index of column `name` (exact match), or -1.
  int Column(std::string_view name) const;
  // "<file>: line N" for messages about a row.
  std::string Where(const CsvRow& row) const;
};

// Parses CSV text. `file` is used in messages only. Throws InputError for an empty file, an
// unterminated quote, a duplicate or empty column name, or a row with the wrong number of fields.
// With `columns` the text has no header line: every non-blank, non-comment line is a row of those
// columns (header_line 0), and the separator comes from the first row — ';', a tab or ',' as
// above, and where it has none of them, runs of blanks (`name x y z` lists).
CsvTable ParseCsv(std::string_view text, const std::string& file,
                  const std::vector<std::string>* columns = nullptr);

// Runs task(0), ..., task(count - 1), side by side where it can; what a failing task throws is
// rethrown, that of the first failing task in task order (parallel/pool.h ForEach is one: base/
// does not start threads itself).
using RunTasks = std::function<void(std::size_t count, const std::function<void(std::size_t)>& task)>;

// ParseCsv with the rows parsed in pieces of whole lines (CsvPieces) that `run` may run side by
// side: the same table and the same first error as one pass.
CsvTable ParseCsv(std::string_view text, const std::string& file, const std::vector<std::string>* columns,
                  const RunTasks& run);

// A CSV text read as ParseCsv reads it, in pieces of whole lines (about 256 KiB each, fixed by the
// text alone) that may be read side by side, without a table of every row (a scan's plan of 10^6
// rows: each row is taken where it is parsed). The constructor reads the header (or takes the
// columns) and the separator, with ParseCsv's errors; `text` must outlive it.
class CsvPieces {
 public:
  CsvPieces(std::string_view text, const std::string& file, const std::vector<std::string>* columns);
  // file, header, header_line and delimiter (no rows).
  const CsvTable& head() const { return head_; }
  std::size_t size() const { return starts_.size(); }
  // Counts the lines and rows of every piece (side by side through `run`); before the rest (Read
  // before it is a std::logic_error).
  void Count(const RunTasks& run);
  std::size_t RowsIn(std::size_t piece) const { return rows_.at(piece); }
  std::size_t rows() const;
  // ParseCsv's error for a file without a header line and without rows.
  void CheckHasRows() const;
  // Parses the rows of `piece` in order and hands each to `take` (which may move its fields);
  // the first error of the piece — a row's, or what `take` throws — ends it.
  void Read(std::size_t piece, const std::function<void(CsvRow&)>& take) const;

 private:
  std::size_t End(std::size_t piece) const;

  std::string_view text_;
  bool headerless_ = false;
  CsvTable head_;
  std::vector<std::size_t> starts_;  // where each piece begins
  std::vector<int> first_lines_;     // the line number of each piece's first line
  std::vector<std::size_t> rows_;    // each piece's rows (Count)
};

// Reads and parses `path`; `label` names it in messages (InputError if it cannot be read).
CsvTable ReadCsvFile(const std::string& path, const std::string& label,
                     const std::vector<std::string>* columns = nullptr);

// A CSV field: a bare decimal number (in the column's unit: value * unit_scale + unit_offset; no
// hex floats, inf or nan) or, when `dim` is given, a quantity with its own unit.
double CsvQuantity(const std::string& field, std::optional<Dimension> dim, double unit_scale,
                   double unit_offset, const std::string& where);
// The same with the message's place `where` + `suffix` (": x"), put together only for a message:
// a plan of 10^6 rows read three coordinates each without building 3 10^6 strings.
double CsvQuantity(const std::string& field, std::optional<Dimension> dim, double unit_scale,
                   double unit_offset, const std::string& where, std::string_view suffix);

}  // namespace vlt::base_internal
