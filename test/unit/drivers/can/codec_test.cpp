// Signal coding: hand-computed tables for Intel and Motorola signals, and a seeded random round
// trip checked against an independent formulation (the payload as one 64-bit integer).
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "ftid/drivers/can/codec.hpp"

namespace ftid::drivers::can {
namespace {

SignalCodec codec(int start, int length, ByteOrder order, bool is_signed, double factor = 1.0,
                  double offset = 0.0) {
  SignalCodec c;
  c.start_bit = static_cast<std::uint16_t>(start);
  c.length = static_cast<std::uint8_t>(length);
  c.byte_order = order;
  c.is_signed = is_signed;
  c.factor = factor;
  c.offset = offset;
  return c;
}

constexpr ByteOrder kIntel = ByteOrder::kLittleEndian;
constexpr ByteOrder kMotorola = ByteOrder::kBigEndian;

struct Row {
  const char* what;
  int start;
  int length;
  ByteOrder order;
  std::uint64_t raw;
  std::uint8_t bytes[8];  // expected payload when only this signal is written into zeros
};

// Worked by hand from the DBC bit numbering (position p = byte p/8, bit p%8).
const Row kRows[] = {
    {"intel byte", 0, 8, kIntel, 0xA5, {0xA5, 0, 0, 0, 0, 0, 0, 0}},
    {"intel 16 at byte 1", 8, 16, kIntel, 0x1234, {0, 0x34, 0x12, 0, 0, 0, 0, 0}},
    {"intel 12 at bit 4", 4, 12, kIntel, 0xABC, {0xC0, 0xAB, 0, 0, 0, 0, 0, 0}},
    {"intel 3 at bit 6 (crosses bytes)", 6, 3, kIntel, 0x5, {0x40, 0x01, 0, 0, 0, 0, 0, 0}},
    {"intel 64", 0, 64, kIntel, 0x0102030405060708ull, {8, 7, 6, 5, 4, 3, 2, 1}},
    {"intel 1 at bit 63", 63, 1, kIntel, 1, {0, 0, 0, 0, 0, 0, 0, 0x80}},
    {"motorola byte", 7, 8, kMotorola, 0xA5, {0xA5, 0, 0, 0, 0, 0, 0, 0}},
    {"motorola 16 at byte 0", 7, 16, kMotorola, 0x1234, {0x12, 0x34, 0, 0, 0, 0, 0, 0}},
    {"motorola 12 from bit 3", 3, 12, kMotorola, 0xABC, {0x0A, 0xBC, 0, 0, 0, 0, 0, 0}},
    {"motorola 4 inside byte 1", 12, 4, kMotorola, 0xF, {0, 0x1E, 0, 0, 0, 0, 0, 0}},
    {"motorola 16 from bit 15", 15, 16, kMotorola, 0xBEEF, {0, 0xBE, 0xEF, 0, 0, 0, 0, 0}},
    {"motorola 10 from bit 1", 1, 10, kMotorola, 0x3FF, {0x03, 0xFF, 0, 0, 0, 0, 0, 0}},
    {"motorola 64", 7, 64, kMotorola, 0x0102030405060708ull, {1, 2, 3, 4, 5, 6, 7, 8}},
};

TEST(Codec, ExtractAndInsertMatchHandComputedTables) {
  for (const Row& r : kRows) {
    const SignalCodec c = codec(r.start, r.length, r.order, false);
    std::uint8_t data[8] = {};
    insertRaw(c, r.raw, data);
    EXPECT_EQ(0, std::memcmp(data, r.bytes, 8)) << r.what;
    EXPECT_EQ(extractRaw(c, r.bytes), r.raw) << r.what;
    // Bits outside the signal are untouched by insert and ignored by extract.
    std::uint8_t ones[8];
    std::memset(ones, 0xFF, 8);
    insertRaw(c, r.raw, ones);
    EXPECT_EQ(extractRaw(c, ones), r.raw) << r.what;
  }
}

TEST(Codec, SignedFactorOffset) {
  // Signed 16-bit Intel at byte 1: raw 0xFFFE = -2 -> -2 * 0.5 + 10 = 9.
  const SignalCodec c = codec(8, 16, kIntel, true, 0.5, 10.0);
  const std::uint8_t data[8] = {0, 0xFE, 0xFF, 0, 0, 0, 0, 0};
  EXPECT_EQ(extractRawSigned(c, data), -2);
  EXPECT_DOUBLE_EQ(decodePhysical(c, data), 9.0);
  // The same bits unsigned: 65534 * 0.5 + 10.
  const SignalCodec u = codec(8, 16, kIntel, false, 0.5, 10.0);
  EXPECT_DOUBLE_EQ(decodePhysical(u, data), 32777.0);
  // Signed 12-bit Motorola from bit 3: raw 0x800 = -2048.
  const SignalCodec m = codec(3, 12, kMotorola, true, 0.01, 0.0);
  const std::uint8_t md[8] = {0x08, 0x00, 0, 0, 0, 0, 0, 0};
  EXPECT_EQ(extractRawSigned(m, md), -2048);
  EXPECT_NEAR(decodePhysical(m, md), -20.48, 1e-12);
  // Encoding rounds to the nearest step and reports saturation.
  std::uint8_t out[8] = {};
  EXPECT_TRUE(encodePhysical(c, 9.26, out));  // (9.26 - 10) / 0.5 = -1.48 -> -1
  EXPECT_EQ(extractRawSigned(c, out), -1);
  EXPECT_FALSE(encodePhysical(c, 1e9, out));   // saturates at +32767
  EXPECT_EQ(extractRawSigned(c, out), 32767);
  EXPECT_FALSE(encodePhysical(c, -1e9, out));  // saturates at -32768
  EXPECT_EQ(extractRawSigned(c, out), -32768);
  EXPECT_FALSE(encodePhysical(c, std::numeric_limits<double>::quiet_NaN(), out));
  EXPECT_FALSE(encodePhysical(u, -20.0, out));  // below unsigned raw 0
  EXPECT_EQ(extractRaw(u, out), 0u);
}

TEST(Codec, RangeCheck) {
  SignalCodec c = codec(0, 16, kIntel, true, 0.05);
  EXPECT_TRUE(inRange(c, 1e6));  // no [min|max] given
  c.has_range = true;
  c.minimum = -300;
  c.maximum = 300;
  EXPECT_TRUE(inRange(c, 300.0));
  EXPECT_TRUE(inRange(c, -300.0));
  EXPECT_FALSE(inRange(c, 300.05));
  EXPECT_FALSE(inRange(c, std::numeric_limits<double>::infinity()));
}

// Independent formulation: Intel = the payload read as a little-endian 64-bit integer, signal at
// bit `start`; Motorola = the payload read as a big-endian 64-bit integer, the signal's MSB at
// big-endian index (start/8)*8 + 7 - start%8 counted from the left.
std::uint64_t referenceExtract(const SignalCodec& c, const std::uint8_t* d) {
  const std::uint64_t mask = c.length == 64 ? ~0ull : ((1ull << c.length) - 1);
  if (c.byte_order == kIntel) {
    std::uint64_t le = 0;
    for (int b = 7; b >= 0; --b) le = (le << 8) | d[b];
    return (le >> c.start_bit) & mask;
  }
  std::uint64_t be = 0;
  for (int b = 0; b < 8; ++b) be = (be << 8) | d[b];
  const int msb = (c.start_bit / 8) * 8 + 7 - c.start_bit % 8;
  return (be >> (64 - msb - c.length)) & mask;
}

TEST(Codec, RandomRoundTripAgreesWithIndependentFormulation) {
  std::mt19937_64 rng(20240611);
  int checked = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const bool intel = (rng() & 1) != 0;
    const int length = 1 + static_cast<int>(rng() % 64);
    int start = 0;
    if (intel) {
      start = static_cast<int>(rng() % static_cast<std::uint64_t>(64 - length + 1));
    } else {
      const int msb = static_cast<int>(rng() % static_cast<std::uint64_t>(64 - length + 1));
      start = (msb / 8) * 8 + 7 - msb % 8;  // big-endian index -> DBC start bit
    }
    const bool is_signed = (rng() & 1) != 0;
    SignalCodec c = codec(start, length, intel ? kIntel : kMotorola, is_signed);
    std::uint8_t data[8];
    for (auto& b : data) b = static_cast<std::uint8_t>(rng());
    std::uint8_t before[8];
    std::memcpy(before, data, 8);
    const std::uint64_t mask = length == 64 ? ~0ull : ((1ull << length) - 1);
    const std::uint64_t raw = rng() & mask;
    insertRaw(c, raw, data);
    ASSERT_EQ(referenceExtract(c, data), raw) << "start " << start << " len " << length;
    ASSERT_EQ(extractRaw(c, data), raw);
    // Other bits unchanged: clear the signal in both copies and compare.
    insertRaw(c, 0, data);
    insertRaw(c, 0, before);
    ASSERT_EQ(0, std::memcmp(data, before, 8));
    // Physical round trip with a factor/offset, for lengths where doubles are exact.
    if (length <= 32) {
      c.factor = 0.25;
      c.offset = -7.0;
      const double lo = is_signed ? -std::ldexp(1.0, length - 1) : 0.0;
      const double span = std::ldexp(1.0, length) - 1.0;
      const double raw_value = lo + std::floor(std::uniform_real_distribution<double>(0, 1)(rng) * span);
      const double physical = raw_value * 0.25 - 7.0;
      ASSERT_TRUE(encodePhysical(c, physical, data));
      ASSERT_DOUBLE_EQ(decodePhysical(c, data), physical);
    }
    ++checked;
  }
  EXPECT_EQ(checked, 20000);
}

}  // namespace
}  // namespace ftid::drivers::can
