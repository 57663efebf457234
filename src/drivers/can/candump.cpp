// candump log files: parsing, formatting and replay.
#include "ftid/drivers/can/candump.hpp"

#include <cctype>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "ftid/fileio/input_file.hpp"
#include "ftid/common/error.hpp"

namespace ftid::drivers::can {

namespace {

int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

CandumpRecord parseCandumpLine(const std::string& text, const std::string& source, int line) {
  const auto fail = [&](const std::string& what) {
    return DataError(source + ":" + std::to_string(line) + ": " + what + " in candump line '" +
                     text + "'");
  };
  CandumpRecord rec;
  std::size_t i = 0;
  const auto skipSpace = [&] {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  };
  skipSpace();
  if (i >= text.size() || text[i] != '(') throw fail("expected '(seconds.fraction)'");
  ++i;
  std::int64_t sec = 0;
  std::size_t digits = 0;
  while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
    sec = sec * 10 + (text[i++] - '0');
    if (++digits > 12) throw fail("timestamp seconds too long");
  }
  if (digits == 0 || i >= text.size() || text[i] != '.') throw fail("malformed timestamp");
  ++i;
  std::int64_t frac_ns = 0;
  std::int64_t scale = 100'000'000;
  digits = 0;
  while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
    frac_ns += (text[i++] - '0') * scale;
    scale /= 10;
    if (++digits > 9) throw fail("timestamp fraction longer than nanoseconds");
  }
  if (digits == 0 || i >= text.size() || text[i] != ')') throw fail("malformed timestamp");
  ++i;
  rec.frame.rx_time_ns = sec * 1'000'000'000 + frac_ns;
  skipSpace();
  const std::size_t if_begin = i;
  while (i < text.size() && !std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  rec.interface = text.substr(if_begin, i - if_begin);
  if (rec.interface.empty()) throw fail("missing interface name");
  skipSpace();
  const std::size_t id_begin = i;
  std::uint32_t id = 0;
  while (i < text.size() && hexValue(text[i]) >= 0) id = (id << 4) | static_cast<std::uint32_t>(hexValue(text[i++]));
  const std::size_t id_len = i - id_begin;
  if (i >= text.size() || text[i] != '#') throw fail("expected ID#DATA");
  ++i;
  can_frame& f = rec.frame.frame;
  std::memset(&f, 0, sizeof f);
  if (id_len == 3) {
    if (id > CAN_SFF_MASK) throw fail("11-bit id out of range");
    f.can_id = id;
  } else if (id_len == 8) {
    // As can-utils: an 8-digit id is extended unless it is an error frame (CAN_ERR_FLAG).
    f.can_id = (id & CAN_ERR_FLAG) ? (id & (CAN_ERR_FLAG | CAN_ERR_MASK))
                                   : ((id & CAN_EFF_MASK) | CAN_EFF_FLAG);
  } else {
    throw fail("the id must have 3 (standard) or 8 (extended) hex digits");
  }
  if (i < text.size() && text[i] == '#') throw fail("CAN FD frames (ID##...) are not supported");
  if (i < text.size() && (text[i] == 'R' || text[i] == 'r')) {
    f.can_id |= CAN_RTR_FLAG;
    ++i;
    if (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
      f.len = static_cast<std::uint8_t>(text[i++] - '0');
      if (f.len > 8) throw fail("remote frame dlc > 8");
    }
  } else {
    int n = 0;
    while (i < text.size() && !std::isspace(static_cast<unsigned char>(text[i]))) {
      if (text[i] == '.') {
        ++i;
        continue;
      }
      if (text[i] == '_') {  // len8_dlc suffix "_X" of classic frames with dlc 9..15
        if (i + 1 >= text.size() || hexValue(text[i + 1]) < 9) throw fail("malformed _dlc suffix");
        f.len8_dlc = static_cast<std::uint8_t>(hexValue(text[i + 1]));
        i += 2;
        continue;
      }
      const int hi = hexValue(text[i]);
      const int lo = i + 1 < text.size() ? hexValue(text[i + 1]) : -1;
      if (hi < 0 || lo < 0) throw fail("data must be pairs of hex digits");
      if (n == 8) throw fail("more than 8 data bytes");
      f.data[n++] = static_cast<std::uint8_t>(hi * 16 + lo);
      i += 2;
    }
    f.len = static_cast<std::uint8_t>(n);
  }
  skipSpace();
  if (i < text.size()) {  // optional direction marker of candump -x
    if ((text[i] == 'R' || text[i] == 'T') && i + 1 == text.size()) {
      ++i;
    } else {
      throw fail("unexpected trailing text");
    }
  }
  return rec;
}

std::string formatCandumpLine(const ReceivedFrame& rf, const std::string& interface) {
  const can_frame& f = rf.frame;
  char buf[96];
  const std::int64_t sec = rf.rx_time_ns / 1'000'000'000;
  const std::int64_t usec = (rf.rx_time_ns % 1'000'000'000) / 1000;
  int n = std::snprintf(buf, sizeof buf, "(%" PRId64 ".%06" PRId64 ") %s ", sec, usec,
                        interface.c_str());
  std::string out(buf, static_cast<std::size_t>(n));
  if (f.can_id & CAN_ERR_FLAG) {
    n = std::snprintf(buf, sizeof buf, "%08" PRIX32 "#", f.can_id & (CAN_ERR_FLAG | CAN_ERR_MASK));
  } else if (f.can_id & CAN_EFF_FLAG) {
    n = std::snprintf(buf, sizeof buf, "%08" PRIX32 "#", f.can_id & CAN_EFF_MASK);
  } else {
    n = std::snprintf(buf, sizeof buf, "%03" PRIX32 "#", f.can_id & CAN_SFF_MASK);
  }
  out.append(buf, static_cast<std::size_t>(n));
  if (f.can_id & CAN_RTR_FLAG) {
    out += 'R';
    if (f.len > 0 && f.len <= 8) out += static_cast<char>('0' + f.len);
    return out;
  }
  static const char* kHex = "0123456789ABCDEF";
  for (int b = 0; b < f.len && b < 8; ++b) {
    out += kHex[f.data[b] >> 4];
    out += kHex[f.data[b] & 0xF];
  }
  return out;
}

std::vector<CandumpRecord> loadCandump(const std::string& path) {
  std::istringstream in;
  try {
    in.str(readInputFile(path, "candump log", kMaxLogBytes));
  } catch (const FileError& e) {
    throw DataError(e.what());
  }
  std::vector<CandumpRecord> out;
  std::string l;
  int line = 0;
  while (std::getline(in, l)) {
    ++line;
    if (!l.empty() && l.back() == '\r') l.pop_back();
    std::size_t k = 0;
    while (k < l.size() && std::isspace(static_cast<unsigned char>(l[k]))) ++k;
    if (k == l.size() || l[k] == '#') continue;
    out.push_back(parseCandumpLine(l, path, line));
  }
  return out;
}

CandumpReplayTransport::CandumpReplayTransport(const std::string& path, bool paced,
                                               const std::string& interface_filter)
    : paced_(paced), description_("candump:" + path) {
  for (auto& r : loadCandump(path)) {
    if (interface_filter.empty() || r.interface == interface_filter) frames_.push_back(r.frame);
  }
}

CandumpReplayTransport::CandumpReplayTransport(std::vector<CandumpRecord> records, bool paced)
    : paced_(paced), description_("candump:memory") {
  frames_.reserve(records.size());
  for (auto& r : records) frames_.push_back(r.frame);
}

std::int64_t CandumpReplayTransport::nextFrameTimeNs() const noexcept {
  return next_ < frames_.size() ? frames_[next_].rx_time_ns : -1;
}

IoResult CandumpReplayTransport::tryReceive(ReceivedFrame& out) noexcept {
  if (next_ >= frames_.size()) return IoResult::kClosed;
  if (paced_ && frames_[next_].rx_time_ns > clock_ns_) return IoResult::kWouldBlock;
  out = frames_[next_++];
  return IoResult::kOk;
}

IoResult CandumpReplayTransport::trySend(const can_frame&) noexcept { return IoResult::kOk; }

bool CandumpReplayTransport::waitReadable(std::chrono::milliseconds) {
  return next_ < frames_.size() && (!paced_ || frames_[next_].rx_time_ns <= clock_ns_);
}

}  // namespace ftid::drivers::can
