// DBC parser for the subset F/T sensors use (see include/ftid/drivers/can/dbc.hpp).
#include "ftid/drivers/can/dbc.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "ftid/fileio/input_file.hpp"
#include "ftid/common/error.hpp"
#include "ftid/drivers/can/codec.hpp"

namespace ftid::drivers::can {

const DbcSignal* DbcMessage::findSignal(const std::string& signal_name) const {
  for (const auto& s : signals) {
    if (s.name == signal_name) return &s;
  }
  return nullptr;
}

const DbcMessage* DbcDatabase::findMessage(const std::string& message_name) const {
  for (const auto& m : messages) {
    if (m.name == message_name) return &m;
  }
  return nullptr;
}

const DbcMessage* DbcDatabase::findMessage(std::uint32_t id, bool extended) const {
  for (const auto& m : messages) {
    if (m.id == id && m.extended == extended) return &m;
  }
  return nullptr;
}

namespace {

// Statements we recognise at the start of a line. Everything not parsed is skipped up to its ';'.
const std::set<std::string>& skippedKeywords() {
  static const std::set<std::string> k = {
      "BS_",        "BO_TX_BU_",    "VAL_",         "VAL_TABLE_",   "BA_DEF_",
      "BA_",        "BA_DEF_DEF_",  "EV_",          "ENVVAR_DATA_", "SGTYPE_",
      "SGTYPE_VAL_", "SIG_GROUP_",  "BA_DEF_REL_",  "BA_REL_",      "BA_DEF_DEF_REL_",
      "BU_SG_REL_", "BU_EV_REL_",   "BU_BO_REL_",   "SIG_TYPE_REF_", "CAT_DEF_",
      "CAT_",       "FILTER",       "EV_DATA_",     "SIGTYPE_VALTYPE_", "BA_DEF_SGTYPE_",
      "BA_SGTYPE_", "SIG_TYPE_REF_"};
  return k;
}

bool isKnownKeyword(const std::string& word) {
  static const std::set<std::string> parsed = {"VERSION", "NS_", "BU_", "BO_", "SG_", "CM_",
                                               "SIG_VALTYPE_", "SG_MUL_VAL_"};
  return parsed.count(word) > 0 || skippedKeywords().count(word) > 0;
}

// First word of a line: letters, digits and '_' (a trailing ':' as in "BU_:" is not included).
std::string firstWord(const std::string& line) {
  std::size_t i = 0;
  while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
  std::size_t j = i;
  while (j < line.size() &&
         (std::isalnum(static_cast<unsigned char>(line[j])) || line[j] == '_'))
    ++j;
  return line.substr(i, j - i);
}

/// A cursor over one statement's text that reports errors with file:line.
class Cursor {
 public:
  Cursor(std::string text, std::string source, int line)
      : s_(std::move(text)), source_(std::move(source)), line_(line) {}

  [[noreturn]] void fail(const std::string& what) const {
    throw DataError(source_ + ":" + std::to_string(line_) + ": " + what);
  }
  void skipSpace() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
  }
  bool atEnd() {
    skipSpace();
    return i_ >= s_.size();
  }
  char peek() {
    skipSpace();
    return i_ < s_.size() ? s_[i_] : '\0';
  }
  bool accept(char c) {
    if (peek() == c) {
      ++i_;
      return true;
    }
    return false;
  }
  void expect(char c, const char* context) {
    if (!accept(c)) {
      std::string got = atEnd() ? std::string("end of line") : std::string("'") + s_[i_] + "'";
      fail(std::string("expected '") + c + "' " + context + ", got " + got);
    }
  }
  std::string identifier(const char* what) {
    skipSpace();
    std::size_t j = i_;
    while (j < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[j])) || s_[j] == '_')) ++j;
    if (j == i_) fail(std::string("expected ") + what);
    std::string out = s_.substr(i_, j - i_);
    i_ = j;
    return out;
  }
  std::uint64_t unsignedInt(const char* what) {
    skipSpace();
    std::size_t j = i_;
    while (j < s_.size() && std::isdigit(static_cast<unsigned char>(s_[j]))) ++j;
    if (j == i_) fail(std::string("expected ") + what + " (an unsigned integer)");
    errno = 0;
    const std::uint64_t v = std::strtoull(s_.substr(i_, j - i_).c_str(), nullptr, 10);
    if (errno == ERANGE) fail(std::string(what) + " is out of range");
    i_ = j;
    return v;
  }
  double number(const char* what) {
    skipSpace();
    const char* begin = s_.c_str() + i_;
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(begin, &end);
    if (end == begin) fail(std::string("expected ") + what + " (a number)");
    if (!std::isfinite(v) || errno == ERANGE) fail(std::string(what) + " is not a finite number");
    i_ += static_cast<std::size_t>(end - begin);
    return v;
  }
  std::string quoted(const char* what) {
    skipSpace();
    if (i_ >= s_.size() || s_[i_] != '"') fail(std::string("expected a quoted ") + what);
    ++i_;
    std::string out;
    while (i_ < s_.size() && s_[i_] != '"') {
      if (s_[i_] == '\\' && i_ + 1 < s_.size()) ++i_;
      out.push_back(s_[i_++]);
    }
    if (i_ >= s_.size()) fail(std::string("unterminated quoted ") + what);
    ++i_;
    return out;
  }
  std::string rest() {
    skipSpace();
    std::string out = s_.substr(i_);
    i_ = s_.size();
    return out;
  }

 private:
  std::string s_;
  std::string source_;
  int line_;
  std::size_t i_ = 0;
};

[[noreturn]] void failAt(const std::string& source, std::size_t index, const std::string& what) {
  throw DataError(source + ":" + std::to_string(index + 1) + ": " + what);
}

struct PendingComment {
  bool is_signal = false;
  std::uint64_t raw_id = 0;
  std::string signal;
  std::string text;
};

// Finds the end of a statement that may span lines (';' outside quotes). Returns the joined text
// and advances `index` to the last line consumed.
std::string gatherStatement(const std::vector<std::string>& lines, std::size_t& index) {
  std::string text;
  bool in_quotes = false;
  for (std::size_t k = index; k < lines.size(); ++k) {
    const std::string& l = lines[k];
    if (k > index && !in_quotes && isKnownKeyword(firstWord(l))) {
      index = k - 1;  // statement without ';' ended before this keyword line
      return text;
    }
    for (std::size_t c = 0; c < l.size(); ++c) {
      const char ch = l[c];
      if (ch == '\\' && in_quotes && c + 1 < l.size()) {
        text.push_back(ch);
        text.push_back(l[++c]);
        continue;
      }
      if (ch == '"') in_quotes = !in_quotes;
      text.push_back(ch);
      if (ch == ';' && !in_quotes) {
        index = k;
        return text;
      }
    }
    text.push_back('\n');
  }
  index = lines.size() - 1;
  return text;
}

void parseSignal(Cursor& c, DbcSignal& s) {
  s.name = c.identifier("a signal name after SG_");
  if (c.peek() != ':') {
    const std::string mux = c.identifier("':' or a multiplexer indicator");
    c.fail("signal '" + s.name + "' is multiplexed ('" + mux +
           "'): multiplexed signals are not supported");
  }
  c.expect(':', "after the signal name");
  const std::uint64_t start = c.unsignedInt("start bit");
  c.expect('|', "between start bit and length");
  const std::uint64_t length = c.unsignedInt("signal length");
  c.expect('@', "before the byte order");
  const char order = c.peek();
  if (order != '0' && order != '1') c.fail("byte order must be @1 (Intel) or @0 (Motorola)");
  c.accept(order);
  const char sign = c.peek();
  if (sign != '+' && sign != '-') c.fail("expected '+' (unsigned) or '-' (signed) after @" +
                                         std::string(1, order));
  c.accept(sign);
  c.expect('(', "before (factor,offset)");
  s.factor = c.number("factor");
  c.expect(',', "between factor and offset");
  s.offset = c.number("offset");
  c.expect(')', "after (factor,offset)");
  c.expect('[', "before [min|max]");
  s.minimum = c.number("minimum");
  c.expect('|', "between minimum and maximum");
  s.maximum = c.number("maximum");
  c.expect(']', "after [min|max]");
  s.unit = c.quoted("unit");
  std::string receivers = c.rest();
  std::replace(receivers.begin(), receivers.end(), ',', ' ');
  std::istringstream rs(receivers);
  for (std::string r; rs >> r;) s.receivers.push_back(r);

  if (length < 1 || length > 64) c.fail("signal '" + s.name + "' length must be 1..64 bits");
  if (start > 511) c.fail("signal '" + s.name + "' start bit is out of range");
  if (s.factor == 0.0) c.fail("signal '" + s.name + "' has factor 0");
  if (s.minimum > s.maximum) c.fail("signal '" + s.name + "' has minimum > maximum");
  s.start_bit = static_cast<int>(start);
  s.length = static_cast<int>(length);
  s.byte_order = order == '1' ? ByteOrder::kLittleEndian : ByteOrder::kBigEndian;
  s.is_signed = sign == '-';
}

void validateMessage(const DbcMessage& m, const std::string& source) {
  const auto where = [&](int line) { return source + ":" + std::to_string(line) + ": "; };
  std::set<std::string> names;
  std::map<int, std::string> owner;  // bit position -> signal name
  int positions[64];
  for (const auto& s : m.signals) {
    if (!names.insert(s.name).second)
      throw DataError(where(s.line) + "duplicate signal '" + s.name + "' in message '" + m.name +
                      "'");
    const SignalCodec codec = SignalCodec::fromDbc(s);
    if (!signalBitPositions(codec, m.dlc, positions))
      throw DataError(where(s.line) + "signal '" + s.name + "' (start bit " +
                      std::to_string(s.start_bit) + ", " + std::to_string(s.length) + " bits, " +
                      (s.byte_order == ByteOrder::kLittleEndian ? "Intel" : "Motorola") +
                      ") does not fit in the " + std::to_string(m.dlc) + "-byte message '" +
                      m.name + "'");
    for (int k = 0; k < s.length; ++k) {
      const auto [it, inserted] = owner.emplace(positions[k], s.name);
      if (!inserted)
        throw DataError(where(s.line) + "signal '" + s.name + "' overlaps signal '" + it->second +
                        "' at bit " + std::to_string(positions[k]) + " of message '" + m.name +
                        "'");
    }
  }
}

/// The lines of `text` (a trailing '\r' removed from each).
std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) {
    if (!l.empty() && l.back() == '\r') l.pop_back();
    lines.push_back(l);
  }
  return lines;
}

/// A BO_ line (line `line_no`): appends the message to db.messages and returns it, or nullptr
/// for Vector's container of unused signals (id 0xC0000000 or VECTOR__INDEPENDENT_SIG_MSG, not a
/// real message: its SG_ lines are skipped). Refuses an id beyond 11 bits (29 with bit 31 set),
/// more than 8 bytes, and an id or name already used.
DbcMessage* parseMessage(const std::string& line, const std::string& source_name, int line_no, DbcDatabase& db) {
  Cursor c(line, source_name, line_no);
  c.identifier("BO_");
  const std::uint64_t raw_id = c.unsignedInt("message id");
  DbcMessage m;
  m.name = c.identifier("a message name");
  c.expect(':', "after the message name");
  const std::uint64_t dlc = c.unsignedInt("message length (dlc)");
  m.transmitter = c.atEnd() ? std::string() : c.identifier("a transmitter node");
  m.line = line_no;
  if (raw_id == 0xC0000000ull || m.name == "VECTOR__INDEPENDENT_SIG_MSG") return nullptr;
  if (raw_id > 0xFFFFFFFFull) c.fail("message id is out of range");
  m.extended = (raw_id & 0x80000000ull) != 0;
  m.id = static_cast<std::uint32_t>(raw_id & 0x7FFFFFFFull);
  if (m.extended ? m.id > 0x1FFFFFFFu : m.id > 0x7FFu)
    c.fail("message id " + std::to_string(raw_id) + " does not fit a " +
           (m.extended ? "29" : "11") + "-bit identifier (set bit 31 for extended ids)");
  if (dlc > 8)
    c.fail("message '" + m.name + "' has " + std::to_string(dlc) +
           " bytes: only classic CAN (0..8 bytes) is supported");
  m.dlc = static_cast<int>(dlc);
  for (const auto& other : db.messages) {
    if (other.id == m.id && other.extended == m.extended)
      c.fail("message id " + std::to_string(raw_id) + " is already used by '" + other.name +
             "' (line " + std::to_string(other.line) + ")");
    if (other.name == m.name)
      c.fail("message name '" + m.name + "' is already used (line " +
             std::to_string(other.line) + ")");
  }
  db.messages.push_back(std::move(m));
  return &db.messages.back();
}

/// A CM_ statement starting on lines[i] (may span lines; `i` advances to its last line): a
/// message's or signal's comment is kept in `comments` (attached once every message is read);
/// other comments are skipped.
void parseComment(const std::vector<std::string>& lines, std::size_t& i, const std::string& source_name,
                  std::vector<PendingComment>& comments) {
  const std::size_t first = i;
  const std::string stmt = gatherStatement(lines, i);
  Cursor c(stmt, source_name, static_cast<int>(first + 1));
  c.identifier("CM_");
  if (c.peek() == '"') return;  // database comment
  const std::string kind = c.identifier("comment target");
  if (kind == "BO_" || kind == "SG_") {
    PendingComment pc;
    pc.is_signal = kind == "SG_";
    pc.raw_id = c.unsignedInt("message id");
    if (pc.is_signal) pc.signal = c.identifier("a signal name");
    pc.text = c.quoted("comment");
    comments.push_back(std::move(pc));
  }
}

/// A SIG_VALTYPE_ statement starting on lines[i] (`i` advances to its last line): refuses
/// IEEE float signals (value type other than 0).
void checkValueType(const std::vector<std::string>& lines, std::size_t& i, const std::string& source_name) {
  const std::size_t first = i;
  const std::string stmt = gatherStatement(lines, i);
  Cursor c(stmt, source_name, static_cast<int>(first + 1));
  c.identifier("SIG_VALTYPE_");
  c.unsignedInt("message id");
  const std::string name = c.identifier("a signal name");
  c.accept(':');
  const std::uint64_t type = c.unsignedInt("value type");
  if (type != 0)
    c.fail("signal '" + name + "' is an IEEE float signal (SIG_VALTYPE_ " +
           std::to_string(type) + "): float signals are not supported");
}

/// Attaches each kept comment to its message or signal (by id; unknown targets are ignored).
void attachComments(const std::vector<PendingComment>& comments, DbcDatabase& db) {
  for (const auto& pc : comments) {
    const bool ext = (pc.raw_id & 0x80000000ull) != 0;
    const auto id = static_cast<std::uint32_t>(pc.raw_id & 0x7FFFFFFFull);
    for (auto& m : db.messages) {
      if (m.id != id || m.extended != ext) continue;
      if (!pc.is_signal) {
        m.comment = pc.text;
      } else {
        for (auto& s : m.signals) {
          if (s.name == pc.signal) s.comment = pc.text;
        }
      }
    }
  }
}

}  // namespace

DbcDatabase parseDbc(const std::string& text, const std::string& source_name) {
  DbcDatabase db;
  db.source = source_name;
  const std::vector<std::string> lines = splitLines(text);
  const auto fail = [&](std::size_t index, const std::string& what) {
    failAt(source_name, index, what);
  };

  DbcMessage* current = nullptr;
  bool current_ignored = false;  // VECTOR__INDEPENDENT_SIG_MSG pseudo message
  bool in_ns = false;
  std::vector<PendingComment> comments;

  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    const int line_no = static_cast<int>(i + 1);
    const std::string word = firstWord(line);
    if (word.empty()) {
      std::size_t k = 0;
      while (k < line.size() && std::isspace(static_cast<unsigned char>(line[k]))) ++k;
      if (k == line.size()) {
        in_ns = false;  // blank line ends the NS_ list
        continue;
      }
      if (line.compare(k, 2, "//") == 0) continue;  // comment line
      fail(i, "unexpected text '" + line.substr(k, 20) + "'");
    }
    if (in_ns) {
      if (std::isspace(static_cast<unsigned char>(line[0]))) continue;  // an NS_ entry
      in_ns = false;
    }

    if (word == "VERSION") {
      Cursor c(line, source_name, line_no);
      c.identifier("VERSION");
      db.version = c.quoted("version string");
    } else if (word == "NS_") {
      in_ns = true;
    } else if (word == "BU_") {
      Cursor c(line, source_name, line_no);
      c.identifier("BU_");
      c.expect(':', "after BU_");
      std::istringstream rs(c.rest());
      for (std::string n; rs >> n;) db.nodes.push_back(n);
    } else if (word == "BO_") {
      current = parseMessage(line, source_name, line_no, db);
      current_ignored = current == nullptr;
    } else if (word == "SG_") {
      if (current_ignored) continue;
      if (current == nullptr) failAt(source_name, i, "SG_ outside a message (no BO_ before it)");
      Cursor c(line, source_name, line_no);
      c.identifier("SG_");
      DbcSignal s;
      s.line = line_no;
      parseSignal(c, s);
      current->signals.push_back(std::move(s));
    } else if (word == "CM_") {
      parseComment(lines, i, source_name, comments);
    } else if (word == "SIG_VALTYPE_") {
      checkValueType(lines, i, source_name);
    } else if (word == "SG_MUL_VAL_") {
      fail(i, "extended multiplexing (SG_MUL_VAL_) is not supported");
    } else if (skippedKeywords().count(word) > 0) {
      if (word == "BS_") continue;  // "BS_:" with optional baud-rate parameters on the line
      gatherStatement(lines, i);
    } else {
      fail(i, "unknown DBC statement '" + word + "'");
    }
  }

  for (const auto& m : db.messages) validateMessage(m, source_name);
  attachComments(comments, db);
  return db;
}

DbcDatabase loadDbc(const std::string& path) {
  try {
    return parseDbc(readInputFile(path, "DBC file", kMaxTextConfigBytes), path);
  } catch (const FileError& e) {
    throw DataError(e.what());
  }
}

}  // namespace ftid::drivers::can
