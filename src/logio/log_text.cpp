// Reading a log's text with the memory budget checked first (include/ftid/logio/log.hpp,
// docs/log-format.md "Limits").
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "ftid/common/error.hpp"
#include "ftid/fileio/input_file.hpp"
#include "ftid/logio/log.hpp"
#include "line_cursor.hpp"

namespace ftid::logio {

namespace {

std::string gigabytes(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f GB", bytes / 1e9);
  return buf;
}

struct HeaderRow {
  std::size_t line_no = 0;  ///< 1-based
  std::size_t length = 0;   ///< characters, without the line end
};

/// The first line that is neither blank nor a '#' comment (the header row); length 0 if none.
HeaderRow headerRow(std::string_view text) {
  LineCursor lines{text};
  std::string_view line;
  while (lines.next(line)) {
    const std::size_t first = line.find_first_not_of(" \t");
    if (first != std::string_view::npos && line[first] != '#') return {lines.line_no, line.size()};
  }
  return {};
}

}  // namespace

std::size_t maxLogRows() {
  const char* env = std::getenv("FTID_MAX_LOG_ROWS");
  if (env == nullptr) return kDefaultMaxLogRows;
  const std::string value(env);
  const bool digits = !value.empty() && value.size() <= 15 &&
                      std::all_of(value.begin(), value.end(), [](char c) { return c >= '0' && c <= '9'; });
  const std::size_t rows = digits ? std::stoull(value) : 0;
  if (rows == 0) {
    throw ConfigError("FTID_MAX_LOG_ROWS='" + value.substr(0, 40) +
                      "' is not a positive whole number of rows (unset it for the default " +
                      std::to_string(kDefaultMaxLogRows) + ")");
  }
  return rows;
}

std::string readLogText(const std::string& path) {
  const std::size_t max_rows = maxLogRows();
  std::string text;
  try {
    text = readInputFile(path, "log file", kMaxLogBytes);
  } catch (const FileError& e) {
    throw DataError(e.what());
  }
  // A UTF-8 byte-order mark (a spreadsheet's "CSV UTF-8") is not part of the first column's name.
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);
  const HeaderRow header = headerRow(text);
  if (header.length > kMaxHeaderBytes) {
    throw DataError(path + ":" + std::to_string(header.line_no) + ":1: header row is " +
                    std::to_string(header.length) + " characters long; at most " + std::to_string(kMaxHeaderBytes) +
                    " are accepted");
  }
  const auto lines = static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) +
                     (!text.empty() && text.back() != '\n' ? 1 : 0);
  const std::size_t rows = lines > 0 ? lines - 1 : 0;  // the header
  if (rows > max_rows) {
    throw DataError(path + ": " + std::to_string(rows) + " data rows; ftid reads at most " +
                    std::to_string(max_rows) + " (it would need about " + gigabytes(static_cast<double>(rows) * kWorkingBytesPerRow) +
                    " of memory, about 2 KB per row). Cut it into parts by time, or resample it, or "
                    "raise the limit with FTID_MAX_LOG_ROWS if the machine has the memory (ftid identify and "
                    "ftid analyze read an ftid log of any length within --max-rows)");
  }
  return text;
}

}  // namespace ftid::logio
