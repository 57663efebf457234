// Line-by-line cursor over a file read in pieces (file_lines.hpp).
#include "file_lines.hpp"

#include <cstring>

#include "ftid/common/error.hpp"

namespace ftid::logio {

FileLineCursor::FileLineCursor(const std::string& path, std::size_t max_file_bytes, std::size_t max_line_bytes,
                               std::size_t chunk_bytes) try
    : path_(path), reader_(path, "log file", max_file_bytes), max_line_(max_line_bytes) {
  buf_.resize(chunk_bytes + max_line_bytes + 2);
} catch (const FileError& e) {
  throw DataError(e.what());  // as readLogText: a log that cannot be read is bad data, named
}

bool FileLineCursor::refill() {
  if (eof_) return false;
  if (begin_ > 0) {
    std::memmove(&buf_[0], &buf_[begin_], end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  std::size_t got = 0;
  try {
    got = reader_.read(&buf_[end_], buf_.size() - end_);
  } catch (const FileError& e) {
    throw DataError(e.what());
  }
  if (got == 0) eof_ = true;
  end_ += got;
  return got > 0;
}

void FileLineCursor::dropByteOrderMark() {
  first_ = false;
  while (end_ - begin_ < 3 && refill()) {
  }
  if (end_ - begin_ >= 3 && std::memcmp(&buf_[begin_], "\xEF\xBB\xBF", 3) == 0) begin_ += 3;
}

[[noreturn]] void FileLineCursor::tooLong() const {
  throw DataError(path_ + ":" + std::to_string(line_no + 1) + ":1: line is longer than " + std::to_string(max_line_) +
                  " characters");
}

bool FileLineCursor::next(std::string_view& line) {
  if (first_) dropByteOrderMark();  // as readLogText drops it from the whole text
  std::size_t scanned = begin_;  // bytes before it hold no '\n'
  while (true) {
    const void* nl = std::memchr(&buf_[scanned], '\n', end_ - scanned);
    const std::size_t stop = nl != nullptr ? static_cast<std::size_t>(static_cast<const char*>(nl) - buf_.data()) : end_;
    if (stop - begin_ > max_line_ + 1) tooLong();  // +1: a '\r' before the '\n' (checked below)
    if (nl != nullptr || (eof_ && stop > begin_)) {
      line = std::string_view(&buf_[begin_], stop - begin_);
      begin_ = nl != nullptr ? stop + 1 : stop;
      break;
    }
    if (eof_) return false;
    scanned = end_ - begin_;  // after refill the unread bytes start at 0
    refill();
    if (eof_ && begin_ == end_) return false;
  }
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  if (line.size() > max_line_) tooLong();
  ++line_no;
  return true;
}

}  // namespace ftid::logio
