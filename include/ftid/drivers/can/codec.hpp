#pragma once
// Pure, allocation-free signal coding between CAN payload bytes and physical values, following
// the DBC rules (docs/sensor.md "Bit numbering"):
//  - little-endian (Intel, @1): the start bit is the signal's least significant bit; bit k of the
//    signal sits at payload position start+k, position p = byte p/8, bit p%8 (bit 0 = LSB).
//  - big-endian (Motorola, @0): the start bit is the signal's most significant bit in the same
//    position numbering; the following (less significant) bits run toward bit 0 of that byte and
//    continue at bit 7 of the next byte ("sawtooth").
// physical = raw * factor + offset, raw two's complement if the signal is signed.
#include <cstdint>

#include "ftid/drivers/can/dbc.hpp"

namespace ftid::drivers::can {

inline constexpr int kClassicCanMaxDlc = 8;

/// The numeric part of a DbcSignal, small and trivially copyable for the real-time path.
struct SignalCodec {
  std::uint16_t start_bit = 0;
  std::uint8_t length = 1;
  ByteOrder byte_order = ByteOrder::kLittleEndian;
  bool is_signed = false;
  bool has_range = false;
  double factor = 1.0;
  double offset = 0.0;
  double minimum = 0.0;
  double maximum = 0.0;

  static SignalCodec fromDbc(const DbcSignal& signal) noexcept;
};

/// Payload bit positions (0..63, byte*8+bit) occupied by the signal, most significant first.
/// Returns false if a bit falls outside `payload_bytes`. `positions` needs room for 64 entries.
bool signalBitPositions(const SignalCodec& codec, int payload_bytes, int* positions) noexcept;

/// Raw (unsigned) bits of the signal, right-aligned. `data` holds 8 bytes.
std::uint64_t extractRaw(const SignalCodec& codec, const std::uint8_t* data) noexcept;

/// Raw value as a signed integer (sign-extended if the signal is signed).
std::int64_t extractRawSigned(const SignalCodec& codec, const std::uint8_t* data) noexcept;

/// Physical value: raw * factor + offset.
double decodePhysical(const SignalCodec& codec, const std::uint8_t* data) noexcept;

/// Writes the low `length` bits of raw into the signal's position; other bits are untouched.
void insertRaw(const SignalCodec& codec, std::uint64_t raw, std::uint8_t* data) noexcept;

/// Encodes a physical value (rounded to the nearest raw step). Returns false if the value had to
/// be saturated to the raw range (or was not finite: then raw 0 is written).
bool encodePhysical(const SignalCodec& codec, double physical, std::uint8_t* data) noexcept;

/// True if the physical value lies within the DBC [min|max] range (always true without a range).
bool inRange(const SignalCodec& codec, double physical) noexcept;

}  // namespace ftid::drivers::can
