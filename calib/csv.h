#pragma once
// CSV: the one reader (and cell rules) behind every owlcal table — observations, dataset
// tables, runner measurement tables, vergence logs, range truth.
//
// Format (RFC 4180): cells separated by ','. A cell may be quoted ("...") and then holds commas,
// doubled quotes ("" reads as ") and line breaks. '\r' before a line break is dropped, so files
// edited on Windows read the same; a UTF-8 byte-order mark at the start of a file is skipped.
// With trim, spaces and tabs around unquoted cells (and around a quoted one) are removed.
// Numbers are strict (io/strict_number.h): no nan, inf, hex, empty cell or trailing text, and
// each reader gives the range a column allows.
//
// Errors throw std::runtime_error naming the file, line and column, e.g.
//   "log.csv:7: column distance_cm = 'nan' is not a finite decimal number"
//   "log.csv:1: missing column 'Rx' (header: distance_cm, Lx)"
//   "log.csv:9: 3 cells, the header has 4"
//
// Usage:
//   const calib::CsvTable t = calib::CsvTable::Read(path, {.trim = true});
//   for (size_t r = 0; r < t.NumRows(); ++r)
//     rows.push_back({t.Number(r, "distance_cm", 0, 1e5), t.Int(r, "Rx", 0, 9999)});
#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <vector>

#include "io/strict_number.h"

namespace owlcal::calib {

// Splits one record (no line break inside) into cells, unquoting quoted ones. Throws
// std::runtime_error "WHERE: ..." on an unterminated quote or text after a closing quote.
std::vector<std::string> SplitCsvLine(const std::string& line,
                                      bool trim = false,
                                      const std::string& where = "CSV line");

// A cell as a writer should put it: quoted (with doubled quotes) when it holds ',', '"', a line
// break, or spaces at either end; as is otherwise.
std::string CsvCell(const std::string& text);

// A number cell with `decimals` digits after the point; an empty cell for NaN or infinity (a
// measurement not made: readers take an empty cell as "none", never a "nan" text).
std::string CsvFixed(double v, int decimals);

// cells[col] as a finite number within [min, max]. Throws std::runtime_error
// "WHERE: missing field FIELD" or "WHERE: field FIELD = 'x' is not a finite decimal number";
// WHERE is usually "path:line".
double CsvNumber(const std::vector<std::string>& cells,
                 int col,
                 const std::string& where,
                 const std::string& field,
                 double min = -io::kNoLimit,
                 double max = io::kNoLimit);
// cells[col] as an integer within [min, max], errors as CsvNumber.
int64_t CsvInteger(const std::vector<std::string>& cells,
                   int col,
                   const std::string& where,
                   const std::string& field,
                   int64_t min,
                   int64_t max);

struct CsvOptions {
  bool trim = false;                   // remove spaces and tabs around cells
  bool skip_blank_lines = true;        // lines holding nothing but separators and spaces are skipped
  bool allow_partial_tail = false;     // a last record with no line break that does not parse (a
                                       // recording cut short) is dropped, see DroppedPartialTail()
  bool tail_needs_line_break = false;  // with allow_partial_tail: an appended log, whose writer
                                       // ends every record with a line break, so a last record
                                       // without one was cut short and is dropped even if it parses
  bool allow_empty = false;            // a file with no complete header row is a table with no columns
};

// A CSV file with a header row, read whole; cells are looked up by column name.
class CsvTable {
 public:
  // Reads a file; throws "PATH: cannot open" or a parse error as above. An empty file (no
  // header) is an error.
  static CsvTable Read(const std::string& path, const CsvOptions& options = {});
  // Parses text; `source` names it in errors.
  static CsvTable Parse(const std::string& text, const std::string& source, const CsvOptions& options = {});

  const std::string& Source() const { return source_; }
  const std::vector<std::string>& Header() const { return header_; }
  size_t NumRows() const { return rows_.size(); }
  bool DroppedPartialTail() const { return dropped_partial_tail_; }
  // Bytes of the text up to the end of the last complete record (a BOM counts): truncating the
  // file there removes a dropped partial tail.
  size_t CompleteBytes() const { return complete_bytes_; }

  // Column index by exact name: -1 (Find) or throws "SOURCE:1: missing column 'name' (header: ...)"
  // or, for a name the header repeats, "SOURCE:1: column 'name' appears twice in the header".
  // Empty and repeated header cells are allowed as long as nothing looks them up.
  int FindColumn(const std::string& name) const;
  int Column(const std::string& name) const;
  bool HasColumn(const std::string& name) const { return FindColumn(name) >= 0; }
  // Throws for the first name the header lacks.
  void RequireColumns(std::initializer_list<const char*> names) const;
  void RequireColumns(std::span<const char* const> names) const;

  // "SOURCE:LINE" of a row (the line its record starts on).
  std::string Where(size_t row) const;
  int Line(size_t row) const { return rows_[row].line; }
  const std::vector<std::string>& Cells(size_t row) const { return rows_[row].cells; }

  // Cell by column name (the column must exist: Column() throws otherwise).
  const std::string& Text(size_t row, const std::string& column) const;
  double Number(size_t row, const std::string& column, double min = -io::kNoLimit, double max = io::kNoLimit) const;
  int64_t Integer(size_t row, const std::string& column, int64_t min, int64_t max) const;
  int Int(size_t row, const std::string& column, int min, int max) const;
  // A number in (0, max]: a length, a distance ("= 0 is not positive" otherwise).
  double PositiveNumber(size_t row, const std::string& column, double max) const;

 private:
  struct Row {
    int line = 0;
    std::vector<std::string> cells;
  };
  std::string source_;
  std::vector<std::string> header_;
  std::vector<Row> rows_;
  bool dropped_partial_tail_ = false;
  size_t complete_bytes_ = 0;
};

}  // namespace owlcal::calib
