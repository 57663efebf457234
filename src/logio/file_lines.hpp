#pragma once
// Line-by-line cursor over a file read in pieces (private to ftid_logio: the streamed log reader,
// docs/log-format.md "Limits"). The same lines as LineCursor over the file's whole text (a line
// ends at '\n', a '\r' before it is dropped, the last line may lack its '\n'; a UTF-8 byte-order
// mark before the first line is dropped as readLogText drops it), holding at most one piece and
// one line in memory.
#include <cstddef>
#include <string>
#include <string_view>

#include "ftid/fileio/input_file.hpp"

namespace ftid::logio {

/// Longest line a streamed log may have [characters]: a longer one (a file without line ends) is
/// refused when this much of it has been read, not after reading it whole.
inline constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;

class FileLineCursor {
 public:
  /// Opens `path` (InputFileReader: a regular file of at most `max_file_bytes`); reads
  /// `chunk_bytes` at a time. Throws DataError naming the file.
  FileLineCursor(const std::string& path, std::size_t max_file_bytes, std::size_t max_line_bytes = kMaxLineBytes,
                 std::size_t chunk_bytes = std::size_t{4} << 20);

  /// Next line (without its line end; valid until the next call); false at the end of the file.
  /// Throws DataError("PATH:N:1: line is longer than ...") for a line beyond max_line_bytes.
  bool next(std::string_view& line);
  /// 1-based number of the line next() returned last.
  std::size_t line_no = 0;
  /// The file's size when it was opened [bytes].
  std::size_t fileSize() const { return reader_.size(); }

 private:
  /// Moves the unread bytes to the front and reads more; false if the file had no more.
  bool refill();
  /// Skips a UTF-8 byte-order mark at the start of the file (reading up to 3 bytes for it).
  void dropByteOrderMark();
  [[noreturn]] void tooLong() const;

  std::string path_;
  InputFileReader reader_;
  std::size_t max_line_;
  std::string buf_;
  std::size_t begin_ = 0;  ///< first unread byte in buf_
  std::size_t end_ = 0;    ///< one past the last valid byte in buf_
  bool eof_ = false;
  bool first_ = true;
};

}  // namespace ftid::logio
