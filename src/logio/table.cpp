// Numeric tables with a header row (include/ftid/logio/table.hpp).
#include "ftid/logio/table.hpp"

#include <charconv>
#include <cmath>
#include <limits>
#include <system_error>
#include <unordered_map>

#include "ftid/common/error.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/logio/log.hpp"
#include "line_cursor.hpp"

namespace ftid::logio {

int Table::find(std::string_view name) const {
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (names[k] == name) return static_cast<int>(k);
  }
  return -1;
}

namespace {

[[noreturn]] void tableError(const std::string& file, std::size_t line, std::size_t column, const std::string& message) {
  throw DataError(file + ":" + std::to_string(line) + ":" + std::to_string(column) + ": " + message);
}

bool isSpace(char c) { return c == ' ' || c == '\t'; }

std::string_view trimmed(std::string_view v) {
  while (!v.empty() && isSpace(v.front())) v.remove_prefix(1);
  while (!v.empty() && (isSpace(v.back()) || v.back() == '\r')) v.remove_suffix(1);
  return v;
}

std::string shortened(std::string_view v) {
  return v.size() <= 40 ? std::string(v) : std::string(v.substr(0, 40)) + "...";
}

/// One field: its text and its 1-based character position in the line.
struct Field {
  std::string_view text;
  std::size_t position;
};

/// Splits a line into fields (comma: every comma separates, fields trimmed; whitespace: runs).
void splitFields(std::string_view line, bool comma, std::vector<Field>& out) {
  out.clear();
  if (comma) {
    std::size_t start = 0;
    while (true) {
      const std::size_t end = line.find(',', start);
      const std::string_view raw = line.substr(start, end == std::string_view::npos ? line.npos : end - start);
      std::size_t lead = 0;
      while (lead < raw.size() && isSpace(raw[lead])) ++lead;
      out.push_back({trimmed(raw), start + lead + 1});
      if (end == std::string_view::npos) break;
      start = end + 1;
    }
    return;
  }
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (isSpace(line[i]) || line[i] == '\r')) ++i;
    if (i >= line.size()) break;
    const std::size_t start = i;
    while (i < line.size() && !isSpace(line[i]) && line[i] != '\r') ++i;
    out.push_back({line.substr(start, i - start), start + 1});
  }
}

bool parseFinite(std::string_view v, double& out, std::string& why) {
  if (v.empty()) {
    why = "empty field";
    return false;
  }
  std::string_view body = v;
  if (body.front() == '+') {
    body.remove_prefix(1);
    if (body.empty() || body.front() == '+' || body.front() == '-') {
      why = "not a number: '" + shortened(v) + "'";
      return false;
    }
  }
  const auto res = std::from_chars(body.data(), body.data() + body.size(), out);
  if (res.ec == std::errc::result_out_of_range) {
    why = "number '" + shortened(v) + "' is out of the range of a double";
    return false;
  }
  if (res.ec != std::errc() || res.ptr != body.data() + body.size()) {
    why = "not a number: '" + shortened(v) + "'";
    return false;
  }
  if (!std::isfinite(out)) {
    why = "non-finite value '" + shortened(v) + "' (NaN and infinity are not allowed)";
    return false;
  }
  return true;
}

bool blankOrComment(std::string_view line) {
  const std::string_view v = trimmed(line);
  return v.empty() || v.front() == '#';
}


}  // namespace

Table parseTable(std::string_view text, const std::string& path, TableSeparator separator,
                 const ColumnFilter& use_column) {
  Table table;
  table.source = path;
  LineCursor lines{text};
  std::string_view line;
  bool have_header = false;
  while (lines.next(line)) {
    if (!blankOrComment(line)) {
      have_header = true;
      break;
    }
  }
  if (!have_header) tableError(path, lines.line_no == 0 ? 1 : lines.line_no, 1, "empty file: no header row");
  table.header_line = lines.line_no;
  if (line.size() > kMaxHeaderBytes) {
    tableError(path, table.header_line, 1,
               "header row is " + std::to_string(line.size()) + " characters long; at most " +
                   std::to_string(kMaxHeaderBytes) + " are accepted");
  }
  const bool comma = separator == TableSeparator::kComma ||
                     (separator == TableSeparator::kAuto && line.find(',') != std::string_view::npos);
  std::vector<Field> fields;
  splitFields(line, comma, fields);
  // "a,b,c," (a writer that ends every line with a comma): the empty last field is no column, and a
  // row's empty last field is dropped too.
  const bool trailing_separator = comma && fields.size() > 1 && fields.back().text.empty();
  if (trailing_separator) fields.pop_back();
  for (Field& f : fields) f.text = unquoted(f.text);
  if (fields.size() > kMaxColumns) {
    tableError(path, table.header_line, fields[kMaxColumns].position,
               "too many columns in the header (at most " + std::to_string(kMaxColumns) + ")");
  }
  std::unordered_map<std::string_view, std::size_t> seen;
  for (const Field& f : fields) {
    if (f.text.empty()) tableError(path, table.header_line, f.position, "empty column name in header");
    const auto [it, inserted] = seen.emplace(f.text, f.position);
    if (!inserted) {
      tableError(path, table.header_line, f.position,
                 "duplicate column '" + shortened(f.text) + "' (first at column " + std::to_string(it->second) + ")");
    }
    table.names.emplace_back(f.text);
    table.name_position.push_back(f.position);
  }
  const std::size_t n = table.names.size();
  table.columns.assign(n, {});
  std::vector<bool> used(n, true);
  if (use_column) {
    for (std::size_t k = 0; k < n; ++k) used[k] = use_column(table.names[k]);
  }
  std::string why;
  while (lines.next(line)) {
    if (blankOrComment(line)) continue;
    splitFields(line, comma, fields);
    if (trailing_separator && fields.size() == n + 1 && fields.back().text.empty()) fields.pop_back();
    for (Field& f : fields) f.text = unquoted(f.text);
    if (fields.size() != n) {
      const bool few = fields.size() < n;
      const std::size_t at = few ? trimmed(line).size() + 1 : fields[n].position;
      tableError(path, lines.line_no, at,
                 std::string(few ? "too few" : "too many") + " fields: expected " + std::to_string(n) +
                     " (as in the header on line " + std::to_string(table.header_line) + "), found " +
                     std::to_string(fields.size()));
    }
    for (std::size_t k = 0; k < n; ++k) {
      double v = std::numeric_limits<double>::quiet_NaN();
      if (used[k] && !parseFinite(fields[k].text, v, why)) {
        tableError(path, lines.line_no, fields[k].position, "column '" + table.names[k] + "': " + why);
      }
      table.columns[k].push_back(v);
    }
    table.row_line.push_back(lines.line_no);
  }
  if (table.rows() == 0) tableError(path, table.header_line, 1, "the file has a header but no data rows");
  return table;
}

Table readTable(const std::string& path, TableSeparator separator, const ColumnFilter& use_column) {
  return parseTable(readLogText(path), path, separator, use_column);
}

std::string_view headerRow(std::string_view text) {
  LineCursor lines{text};
  std::string_view line;
  while (lines.next(line)) {
    if (!blankOrComment(line)) return line.substr(0, kMaxHeaderBytes);
  }
  return {};
}

}  // namespace ftid::logio
