#pragma once
// DBC files (Vector's CAN database format): the subset F/T sensors use. docs/sensor.md lists the
// supported statements. Parsed once at set-up; errors are ftid::DataError naming "file:line: ...".
//
//   VERSION "..."                          kept
//   NS_ : ... / BS_: / BU_: nodes          NS_/BS_ skipped, BU_ kept
//   BO_ <id> <Name>: <dlc> <Transmitter>   a message (id bit 31 set = 29-bit extended id)
//    SG_ <Name> : <start>|<len>@<1|0><+|-> (<factor>,<offset>) [<min>|<max>] "<unit>" <Rx,...>
//   CM_ BO_/SG_ "...";                     attached to the message/signal; other CM_ skipped
//   VAL_, VAL_TABLE_, BA_DEF_, BA_, ...    skipped gracefully (may span lines)
//   multiplexed signals (M / mN), SIG_VALTYPE_ (float signals), CAN FD dlc > 8: rejected clearly
#include <cstdint>
#include <string>
#include <vector>

namespace ftid::drivers::can {

/// Byte order of a signal: DBC `@1` is little-endian (Intel), `@0` big-endian (Motorola).
enum class ByteOrder : std::uint8_t { kLittleEndian = 1, kBigEndian = 0 };

struct DbcSignal {
  std::string name;
  int start_bit = 0;  ///< DBC start bit: LSB for Intel, MSB (sawtooth numbering) for Motorola
  int length = 1;     ///< bits, 1..64
  ByteOrder byte_order = ByteOrder::kLittleEndian;
  bool is_signed = false;  ///< two's complement raw value
  double factor = 1.0;     ///< physical = raw * factor + offset
  double offset = 0.0;
  double minimum = 0.0;    ///< physical range; [0|0] means "no range given"
  double maximum = 0.0;
  std::string unit;
  std::vector<std::string> receivers;
  std::string comment;  ///< from CM_ SG_, if any
  int line = 0;         ///< line of the SG_ statement

  bool hasRange() const { return !(minimum == 0.0 && maximum == 0.0); }
};

struct DbcMessage {
  std::uint32_t id = 0;   ///< CAN identifier without flags (11 or 29 bits)
  bool extended = false;  ///< 29-bit identifier
  std::string name;
  int dlc = 8;            ///< payload bytes, 0..8 (classic CAN)
  std::string transmitter;
  std::vector<DbcSignal> signals;
  std::string comment;  ///< from CM_ BO_, if any
  int line = 0;         ///< line of the BO_ statement

  /// The signal with this name, or nullptr.
  const DbcSignal* findSignal(const std::string& signal_name) const;
};

struct DbcDatabase {
  std::string source;   ///< file name (or the name given to parseDbc) used in messages
  std::string version;  ///< VERSION string, may be empty
  std::vector<std::string> nodes;  ///< BU_
  std::vector<DbcMessage> messages;

  const DbcMessage* findMessage(const std::string& message_name) const;
  const DbcMessage* findMessage(std::uint32_t id, bool extended) const;
};

/// Parses DBC text. `source_name` is used in error messages ("<source_name>:<line>: ...").
/// Throws ftid::DataError on syntax errors, signals that do not fit the message's dlc, overlapping
/// signals, duplicate names or ids, and unsupported constructs (multiplexing, float signals).
DbcDatabase parseDbc(const std::string& text, const std::string& source_name);

/// Reads and parses a DBC file; throws ftid::DataError (naming the file) if it cannot be read.
DbcDatabase loadDbc(const std::string& path);

}  // namespace ftid::drivers::can
