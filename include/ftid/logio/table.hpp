#pragma once
// A numeric table from a text file with a header row: the common ground of the recordings ftid
// reads besides its own log (UR's record.py / ur_rtde files, a sensor's own wrench log;
// docs/log-format.md). Every value is a finite number; every error names FILE:LINE:COLUMN.
#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace ftid::logio {

struct Table {
  std::string source;                         ///< file path (for messages)
  std::size_t header_line = 0;                ///< 1-based line of the header row
  std::vector<std::string> names;             ///< column names, in file order
  std::vector<std::size_t> name_position;     ///< 1-based character position of each name
  std::vector<std::vector<double>> columns;   ///< columns[k][i]: column k, row i
  std::vector<std::size_t> row_line;          ///< 1-based file line of each row

  std::size_t rows() const { return row_line.size(); }
  /// Index of a column by exact name, or -1.
  int find(std::string_view name) const;
};

/// Separator of a table's fields: ',' (any comma in the header), else runs of spaces/tabs.
enum class TableSeparator { kAuto, kComma, kWhitespace };

/// Parses `text` (named `path` in messages). Blank lines and lines starting with '#' are skipped;
/// the first other line is the header. Limits as for ftid logs (kMaxColumns, kMaxHeaderBytes).
/// Throws DataError("FILE:LINE:COLUMN: message") for an empty table, empty or duplicate names, a
/// field that is not a finite number, or a row with too few or too many fields.
/// With `use_column`, only the columns it accepts (by header name) are parsed as numbers; the
/// others may hold anything (a hex status, a date) and read as NaN.
using ColumnFilter = std::function<bool(const std::string&)>;
Table parseTable(std::string_view text, const std::string& path, TableSeparator separator = TableSeparator::kAuto,
                 const ColumnFilter& use_column = {});

/// Reads a regular file (fileio's bounded, non-blocking input reader) and parses it.
Table readTable(const std::string& path, TableSeparator separator = TableSeparator::kAuto,
                const ColumnFilter& use_column = {});

/// The header row of a text (its first line that is neither blank nor a comment; for recognising
/// the format), at most kMaxHeaderBytes long; empty if there is none.
std::string_view headerRow(std::string_view text);

}  // namespace ftid::logio
