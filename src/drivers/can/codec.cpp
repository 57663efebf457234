// Pure DBC signal coding (see include/ftid/drivers/can/codec.hpp for the bit numbering rules).
#include "ftid/drivers/can/codec.hpp"

#include <cmath>

namespace ftid::drivers::can {

SignalCodec SignalCodec::fromDbc(const DbcSignal& signal) noexcept {
  SignalCodec c;
  c.start_bit = static_cast<std::uint16_t>(signal.start_bit);
  c.length = static_cast<std::uint8_t>(signal.length);
  c.byte_order = signal.byte_order;
  c.is_signed = signal.is_signed;
  c.has_range = signal.hasRange();
  c.factor = signal.factor;
  c.offset = signal.offset;
  c.minimum = signal.minimum;
  c.maximum = signal.maximum;
  return c;
}

namespace {

// Calls f(position) for each bit of the signal, most significant bit first. Returns false (and
// stops) if a position leaves [0, limit).
template <typename F>
bool forEachBitMsbFirst(const SignalCodec& c, int limit, F&& f) noexcept {
  const int n = c.length;
  if (c.byte_order == ByteOrder::kLittleEndian) {
    for (int k = n - 1; k >= 0; --k) {
      const int pos = c.start_bit + k;
      if (pos < 0 || pos >= limit) return false;
      f(pos);
    }
    return true;
  }
  int pos = c.start_bit;
  for (int k = 0; k < n; ++k) {
    if (pos < 0 || pos >= limit) return false;
    f(pos);
    pos = (pos % 8 == 0) ? pos + 15 : pos - 1;
  }
  return true;
}

inline std::uint64_t lowMask(int bits) noexcept {
  return bits >= 64 ? ~std::uint64_t{0} : ((std::uint64_t{1} << bits) - 1u);
}

}  // namespace

bool signalBitPositions(const SignalCodec& codec, int payload_bytes, int* positions) noexcept {
  int k = 0;
  return forEachBitMsbFirst(codec, payload_bytes * 8, [&](int pos) { positions[k++] = pos; });
}

std::uint64_t extractRaw(const SignalCodec& codec, const std::uint8_t* data) noexcept {
  std::uint64_t raw = 0;
  if (codec.byte_order == ByteOrder::kLittleEndian && codec.start_bit % 8 == 0 &&
      codec.length % 8 == 0 && codec.start_bit / 8 + codec.length / 8 <= kClassicCanMaxDlc) {
    // Byte-aligned Intel signal (the common case): assemble whole bytes.
    const int first = codec.start_bit / 8;
    for (int b = codec.length / 8 - 1; b >= 0; --b) raw = (raw << 8) | data[first + b];
    return raw;
  }
  forEachBitMsbFirst(codec, kClassicCanMaxDlc * 8, [&](int pos) {
    raw = (raw << 1) | ((data[pos / 8] >> (pos % 8)) & 1u);
  });
  return raw;
}

std::int64_t extractRawSigned(const SignalCodec& codec, const std::uint8_t* data) noexcept {
  std::uint64_t raw = extractRaw(codec, data);
  if (codec.is_signed && codec.length < 64 && ((raw >> (codec.length - 1)) & 1u) != 0) {
    raw |= ~lowMask(codec.length);
  }
  return static_cast<std::int64_t>(raw);
}

double decodePhysical(const SignalCodec& codec, const std::uint8_t* data) noexcept {
  const double raw = codec.is_signed ? static_cast<double>(extractRawSigned(codec, data))
                                     : static_cast<double>(extractRaw(codec, data));
  return raw * codec.factor + codec.offset;
}

void insertRaw(const SignalCodec& codec, std::uint64_t raw, std::uint8_t* data) noexcept {
  int k = codec.length - 1;  // bit index of the signal, MSB first
  forEachBitMsbFirst(codec, kClassicCanMaxDlc * 8, [&](int pos) {
    const auto bit = static_cast<std::uint8_t>(1u << (pos % 8));
    if ((raw >> k) & 1u) {
      data[pos / 8] = static_cast<std::uint8_t>(data[pos / 8] | bit);
    } else {
      data[pos / 8] = static_cast<std::uint8_t>(data[pos / 8] & ~bit);
    }
    --k;
  });
}

bool encodePhysical(const SignalCodec& codec, double physical, std::uint8_t* data) noexcept {
  if (!std::isfinite(physical)) {
    insertRaw(codec, 0, data);
    return false;
  }
  const double scaled = std::nearbyint((physical - codec.offset) / codec.factor);
  double lo = 0.0;
  double hi = 0.0;
  if (codec.is_signed) {
    lo = -std::ldexp(1.0, codec.length - 1);
    hi = std::ldexp(1.0, codec.length - 1) - 1.0;
  } else {
    hi = std::ldexp(1.0, codec.length) - 1.0;
  }
  bool ok = true;
  double clamped = scaled;
  if (clamped < lo) {
    clamped = lo;
    ok = false;
  } else if (clamped > hi) {
    clamped = hi;
    ok = false;
  }
  std::uint64_t raw = 0;
  if (codec.is_signed) {
    // hi of a 64-bit signal is not representable exactly; clamp in the integer domain.
    const std::int64_t v = clamped >= 9.2233720368547758e18
                               ? INT64_MAX
                               : static_cast<std::int64_t>(clamped);
    raw = static_cast<std::uint64_t>(v) & lowMask(codec.length);
  } else {
    raw = clamped >= 1.8446744073709552e19 ? ~std::uint64_t{0}
                                           : static_cast<std::uint64_t>(clamped);
  }
  insertRaw(codec, raw, data);
  return ok;
}

bool inRange(const SignalCodec& codec, double physical) noexcept {
  if (!std::isfinite(physical)) return false;
  if (!codec.has_range) return true;
  const double tol = 1e-9 * std::fabs(codec.factor);
  return physical >= codec.minimum - tol && physical <= codec.maximum + tol;
}

}  // namespace ftid::drivers::can
