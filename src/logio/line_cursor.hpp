#pragma once
// Line-by-line cursor over a text held in memory (private to ftid_logio: the log reader, the table
// reader and readLogText). A line ends at '\n' (a '\r' before it is dropped) or at the end of the
// text; line numbers are 1-based and count every line, blank and comment lines included.
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

}  // namespace ftid::logio
