#pragma once
// Line-by-line cursor over a text held in memory (private to ftid_logio: the log reader, the table
// reader and readLogText). A line ends at '\n' (a '\r' before it is dropped) or at the end of the
// text; line numbers are 1-based and count every line, blank and comment lines included. Also the
// field helpers the text readers share (docs/log-format.md "Files from other tools").
#include <cstddef>
#include <string_view>

namespace ftid::logio {

struct LineCursor {
  std::string_view text;
  std::size_t pos = 0;
  std::size_t line_no = 0;
  /// Next line (without its line end); false at the end of the text.
  bool next(std::string_view& line) {
    if (pos >= text.size()) return false;
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    line = text.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = end + 1;
    ++line_no;
    return true;
  }
};

/// A field without one pair of surrounding double quotes ("t" -> t; spreadsheets and csv writers
/// that quote every field): unquoted(unquoted(x)) == unquoted(x) only for fields that were quoted
/// once, so a field is unquoted once.
inline std::string_view unquoted(std::string_view field) {
  if (field.size() >= 2 && field.front() == '"' && field.back() == '"') return field.substr(1, field.size() - 2);
  return field;
}

/// The header of a comma-separated text that separates its fields with ';' or tabs instead (no
/// comma at all): the reason to refuse it, else "". A spreadsheet in a locale with decimal commas
/// writes ';' between fields.
inline const char* otherSeparator(std::string_view header) {
  if (header.find(',') != std::string_view::npos) return "";
  if (header.find(';') != std::string_view::npos) {
    return "the header's fields are separated by ';' (a spreadsheet's CSV export in a locale with decimal "
           "commas?): ftid reads comma-separated logs with decimal points; export with ',' between fields and '.' "
           "as the decimal mark";
  }
  if (header.find('\t') != std::string_view::npos) {
    return "the header's fields are separated by tabs: ftid logs are comma-separated; replace the tabs with "
           "commas (a sensor's own whitespace-separated recording is read with --wrench-log)";
  }
  return "";
}

}  // namespace ftid::logio
