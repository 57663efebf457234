// The one safe decode of received LCM bytes (transport::tryDecode / decodeFrom, codec.hpp) and
// the outbox's command subscription built on it (issue 26, item 1): lcm-gen's decoder calls
// string::assign(p, length - 1), so a string length field of 0 (or below) throws
// std::length_error; one such 69-byte command_t ended ftidd, an 82-byte ack_t ended `ftid tare`.
// The malformed messages are built here byte by byte from the LCM wire format (big-endian,
// 8-byte fingerprint, strings as int32 length including the terminating 0).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_outbox.hpp"

namespace ftid::transport {
namespace {

using Bytes = std::vector<std::uint8_t>;

void putBe(Bytes* b, std::uint64_t v, int n) {
  for (int i = n - 1; i >= 0; --i) b->push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

// The issue's datagram: command_t with the argument's length field 0 (8+8+8+1+4+8+32 = 69).
Bytes zeroLengthCommand() {
  Bytes b;
  putBe(&b, static_cast<std::uint64_t>(ftid_lcm::command_t::getHash()), 8);
  putBe(&b, 1700000000000000ULL, 8);  // utime
  putBe(&b, 42, 8);                   // request_id
  putBe(&b, 2, 1);                    // command = PING
  putBe(&b, 0, 4);                    // argument length 0: not even the terminating 0
  putBe(&b, 7, 8);                    // sequence
  b.insert(b.end(), 32, 0xAB);        // mac
  return b;
}

// ack_t with the message's length field `len` (8+8+8+1+1+4+4+48 = 82 bytes for an empty body).
Bytes ackWithLength(std::uint32_t len, std::int64_t request_id = 42) {
  Bytes b;
  putBe(&b, static_cast<std::uint64_t>(ftid_lcm::ack_t::getHash()), 8);
  putBe(&b, 1700000000000000ULL, 8);
  putBe(&b, static_cast<std::uint64_t>(request_id), 8);
  putBe(&b, 3, 1);   // command = TARE
  putBe(&b, 1, 1);   // ok
  putBe(&b, 9, 4);   // param_version
  putBe(&b, len, 4);
  b.insert(b.end(), 48, 0);  // offsets
  return b;
}

template <class Msg>
Bytes encode(const Msg& m) {
  Bytes b(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

TEST(LcmDecode, TheIssuesCommandDatagramIsRefusedWithAReason) {
  const Bytes bad = zeroLengthCommand();
  ASSERT_EQ(bad.size(), 69u);
  // The hazard itself: the generated decoder throws on these bytes.
  ftid_lcm::command_t raw;
  EXPECT_THROW(raw.decode(bad.data(), 0, static_cast<int>(bad.size())), std::length_error);
  ftid_lcm::command_t msg;
  const char* why = tryDecode(bad.data(), bad.size(), &msg);
  ASSERT_NE(why, nullptr);
  EXPECT_NE(std::string(why).find("string length below 1"), std::string::npos) << why;
  EXPECT_FALSE(decodeFrom(bad.data(), bad.size(), &msg));
  // A negative length (0xFFFFFFFF) too.
  Bytes neg = bad;
  for (int i = 25; i < 29; ++i) neg[static_cast<std::size_t>(i)] = 0xFF;
  EXPECT_FALSE(decodeFrom(neg.data(), neg.size(), &msg));
}

TEST(LcmDecode, AcksAndResultsWithBadStringsAreRefused) {
  ftid_lcm::ack_t ack;
  const Bytes zero = ackWithLength(0);
  ASSERT_EQ(zero.size(), 82u);
  EXPECT_THROW(ack.decode(zero.data(), 0, static_cast<int>(zero.size())), std::length_error);
  EXPECT_FALSE(decodeFrom(zero.data(), zero.size(), &ack));
  // A length beyond the message, and one whose last byte is not the terminating 0.
  const Bytes longer = ackWithLength(1000);
  EXPECT_STREQ(tryDecode(longer.data(), longer.size(), &ack), "string length beyond the end of the message");
  Bytes unterminated = ackWithLength(1);
  unterminated.insert(unterminated.begin() + 34, 'x');
  EXPECT_STREQ(tryDecode(unterminated.data(), unterminated.size(), &ack), "string not terminated by 0");
  Bytes embedded = ackWithLength(3);  // "a\0\0": a 0 inside the string
  embedded.insert(embedded.begin() + 34, {'a', 0, 0});
  EXPECT_STREQ(tryDecode(embedded.data(), embedded.size(), &ack), "string with a 0 before its end");
  Bytes good = ackWithLength(1);
  good.insert(good.begin() + 34, 0);
  ASSERT_EQ(tryDecode(good.data(), good.size(), &ack), nullptr);
  EXPECT_EQ(ack.request_id, 42);
  EXPECT_EQ(ack.param_version, 9);

  // identification_result_t: 131 strings; the last one (message) with length 0.
  ftid_lcm::identification_result_t r{};
  r.model = "paper";
  r.message = "x";
  Bytes b = encode(r);
  ASSERT_EQ(tryDecode(b.data(), b.size(), &r), nullptr);
  // message is the last field: its length field sits 4 + 2 bytes before the end ("x\0").
  b[b.size() - 3] = 0;  // length 2 -> 0 (the length's low byte)
  b.resize(b.size() - 2);
  ftid_lcm::identification_result_t raw;
  EXPECT_THROW(raw.decode(b.data(), 0, static_cast<int>(b.size())), std::length_error);
  EXPECT_NE(tryDecode(b.data(), b.size(), &r), nullptr);
}

TEST(LcmDecode, SizesMustMatchExactly) {
  ftid_lcm::command_t c{};
  c.argument = "abc";
  Bytes b = encode(c);
  ASSERT_TRUE(decodeFrom(b.data(), b.size(), &c));
  EXPECT_EQ(c.argument, "abc");
  Bytes trailing = b;
  trailing.push_back(0);
  EXPECT_STREQ(tryDecode(trailing.data(), trailing.size(), &c), "trailing bytes after the message");
  EXPECT_STREQ(tryDecode(b.data(), b.size() - 1, &c), "message truncated");
  EXPECT_NE(tryDecode(b.data(), 0, &c), nullptr);
  EXPECT_NE(tryDecode(nullptr, 10, &c), nullptr);
  // Fixed-size types: exactly their encoded size, and the fingerprint of the type.
  ftid_lcm::compensated_wrench_t w{};
  Bytes wb = encode(w);
  EXPECT_TRUE(decodeFrom(wb.data(), wb.size(), &w));
  wb.push_back(1);
  EXPECT_FALSE(decodeFrom(wb.data(), wb.size(), &w));
  ftid_lcm::cycle_sample_t cs{};
  Bytes cb = encode(cs);
  EXPECT_TRUE(decodeFrom(cb.data(), cb.size(), &cs));
  EXPECT_FALSE(decodeFrom(cb.data(), cb.size(), &w));  // another type's bytes
  cb[0] ^= 1;                                          // a wrong fingerprint
  EXPECT_FALSE(decodeFrom(cb.data(), cb.size(), &cs));
}

// Random corruptions of valid messages (seeded): tryDecode never throws (it is noexcept: a
// throw would terminate the test), and whatever it accepts re-encodes to the same bytes.
template <class Msg>
void corruptAndDecode(const Msg& valid, std::uint32_t seed, int rounds) {
  std::mt19937 rng(seed);
  const Bytes base = encode(valid);
  int accepted = 0;
  for (int i = 0; i < rounds; ++i) {
    Bytes b = base;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e) {
      const std::size_t at = rng() % b.size();
      switch (rng() % 4) {
        case 0: b[at] = static_cast<std::uint8_t>(rng()); break;
        case 1: b.erase(b.begin() + static_cast<std::ptrdiff_t>(at)); break;
        case 2: b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), static_cast<std::uint8_t>(rng())); break;
        default: b[at] = 0; break;
      }
      if (b.empty()) b.push_back(0);
    }
    Msg m;
    if (decodeFrom(b.data(), b.size(), &m)) {
      ++accepted;
      EXPECT_EQ(encode(m), b) << "seed " << seed << " round " << i;
    }
  }
  EXPECT_LT(accepted, rounds);
}

TEST(LcmDecode, RandomCorruptionsNeverThrowAndWhatIsAcceptedIsExact) {
  ftid_lcm::command_t c{};
  c.argument = "a path";
  ftid_lcm::ack_t a{};
  a.message = "tared";
  ftid_lcm::identification_result_t r{};
  r.model = "paper";
  r.num_params = 2;
  r.param_names[0] = "mass";
  for (std::uint32_t seed = 1; seed <= 20; ++seed) {
    corruptAndDecode(c, seed, 500);
    corruptAndDecode(a, seed, 500);
    corruptAndDecode(r, seed, 100);
    corruptAndDecode(ftid_lcm::loop_stats_t{}, seed, 200);
  }
}

struct Seen {
  std::atomic<int> count{0};
  std::atomic<std::int64_t> id{0};
  static void record(const ftid_lcm::command_t& c, void* ctx) {
    auto* s = static_cast<Seen*>(ctx);
    s->id.store(c.request_id);
    s->count.fetch_add(1);
  }
};

// The outbox (ftidd's command receiver) survives the 69-byte datagram: it is dropped and
// counted, and the next well-formed command is still dispatched. Before the fix the
// std::length_error escaped LcmOutbox's thread and the process aborted.
TEST(LcmDecode, TheOutboxDropsAndCountsTheMalformedCommandAndGoesOn) {
  lcm::LCM lc("memq://");
  LcmOutbox outbox(OutboxOptions{}, &lc);
  Seen seen;
  outbox.setCommandHandler(&Seen::record, &seen);
  outbox.start();
  const Bytes bad = zeroLengthCommand();
  ASSERT_EQ(lc.publish("FTID_COMMAND", bad.data(), static_cast<unsigned>(bad.size())), 0);
  ASSERT_EQ(lc.publish("FTID_COMMAND", bad.data(), 10), 0);  // truncated as well
  ftid_lcm::command_t good{};
  good.request_id = 4711;
  good.argument = "";
  ASSERT_EQ(lc.publish("FTID_COMMAND", &good), 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (seen.count.load() < 1 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  outbox.stop();
  EXPECT_EQ(seen.count.load(), 1);
  EXPECT_EQ(seen.id.load(), 4711);
  EXPECT_EQ(outbox.counters().commands, 3u);
  EXPECT_EQ(outbox.counters().malformed, 2u);
}

}  // namespace
}  // namespace ftid::transport
