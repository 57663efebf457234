#pragma once
// Codec between the domain records (ftid/common/records.hpp) and the generated LCM types
// (lcmtypes/*.lcm, package ftid_lcm). The to*/from* conversions and encodeInto() are
// real-time safe: no allocation, no exceptions (every message they touch has fixed-size
// fields only). Call warmUpCodec() once outside the loop: lcm-gen's getHash() initialises a
// function-local static on first use.
#include <cstddef>
#include <cstdint>

// lcm-gen's decode() trips GCC's -Wmaybe-uninitialized (a false positive on msg_hash) where it
// is inlined; the warning is attributed to the generated headers, so silence it for them only.
#pragma GCC diagnostic push
#if defined(__GNUC__) && !defined(__clang__)  // GCC only (clang, e.g. clang-tidy, lacks the group)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <ftid_lcm/ack_t.hpp>
#include <ftid_lcm/command_t.hpp>
#include <ftid_lcm/compensated_wrench_t.hpp>
#include <ftid_lcm/cycle_sample_t.hpp>
#include <ftid_lcm/identification_result_t.hpp>
#include <ftid_lcm/loop_stats_t.hpp>
#include <ftid_lcm/robot_state_t.hpp>
#include <ftid_lcm/sensor_sample_t.hpp>
#pragma GCC diagnostic pop

#include "ftid/common/records.hpp"

namespace ftid::transport {

void toLcm(const RobotStateRecord& in, ftid_lcm::robot_state_t* out) noexcept;
void toLcm(const SensorSampleRecord& in, ftid_lcm::sensor_sample_t* out) noexcept;
void toLcm(const CycleRecord& in, ftid_lcm::cycle_sample_t* out) noexcept;
void toLcm(const CycleRecord& in, ftid_lcm::compensated_wrench_t* out) noexcept;
void toLcm(const LoopStatsRecord& in, ftid_lcm::loop_stats_t* out) noexcept;

void fromLcm(const ftid_lcm::robot_state_t& in, RobotStateRecord* out) noexcept;
void fromLcm(const ftid_lcm::sensor_sample_t& in, SensorSampleRecord* out) noexcept;
/// Restores the cycle_sample_t part of a CycleRecord (robot, sensor, age, faults).
void fromLcm(const ftid_lcm::cycle_sample_t& in, CycleRecord* out) noexcept;
/// Restores the compensated_wrench_t part of a CycleRecord (wrenches, validity, versions,
/// sensor receive time and the robot timestamp).
void fromLcm(const ftid_lcm::compensated_wrench_t& in, CycleRecord* out) noexcept;
void fromLcm(const ftid_lcm::loop_stats_t& in, LoopStatsRecord* out) noexcept;

/// Encodes msg (with its type fingerprint) into buf. Returns the number of bytes written, or -1
/// if capacity is too small. Allocation-free for messages without strings or variable arrays.
template <class Msg>
int encodeInto(const Msg& msg, std::uint8_t* buf, std::size_t capacity) noexcept {
  return msg.encode(buf, 0, static_cast<int>(capacity));
}

/// Why the received bytes buf[0, size) cannot be a well-formed message of the type, or nullptr.
/// Walks the wire form without decoding: every string length is at least 1 (lcm-gen's decoder
/// calls string::assign(p, length - 1), so a length of 0 or below throws std::length_error) and
/// within the buffer, every string ends in its 0 and holds no other 0, and the message ends
/// exactly at size (no
/// truncation, no trailing bytes). The fingerprint is checked by the decoder. Allocation-free.
const char* findWireProblem(const void* buf, std::size_t size, const ftid_lcm::command_t*) noexcept;
const char* findWireProblem(const void* buf, std::size_t size, const ftid_lcm::ack_t*) noexcept;
const char* findWireProblem(const void* buf, std::size_t size,
                            const ftid_lcm::identification_result_t*) noexcept;
/// The fixed-size types (no strings, no variable arrays): the size must be the encoded size.
template <class Msg>
const char* findWireProblem(const void* /*buf*/, std::size_t size, const Msg* /*type*/) noexcept {
  return size == static_cast<std::size_t>(Msg{}.getEncodedSize()) ? nullptr
                                                                   : "wrong size for the message type";
}

/// The one safe decode of received bytes (every LCM subscriber in ftid uses it): the wire form
/// is checked first (findWireProblem), then decoded, the fingerprint checked and the decoded
/// length compared with size; any exception of the generated decoder is caught. Returns nullptr
/// on success, else the reason (a static string) and *msg is unspecified. Never throws.
template <class Msg>
const char* tryDecode(const void* buf, std::size_t size, Msg* msg) noexcept {
  if (buf == nullptr || size == 0) return "empty message";
  if (size > (1U << 30)) return "message larger than 1 GiB";
  if (const char* problem = findWireProblem(buf, size, static_cast<const Msg*>(msg))) return problem;
  try {
    const int n = msg->decode(buf, 0, static_cast<int>(size));
    if (n < 0) return "wrong fingerprint (another message type) or truncated";
    if (static_cast<std::size_t>(n) != size) return "decoded length differs from the message size";
  } catch (...) {  // std::length_error / std::bad_alloc from a string the walk let through
    return "the decoder threw";
  }
  return nullptr;
}

/// Decodes received bytes (tryDecode). False on anything that is not exactly one well-formed
/// message of the type; never throws.
template <class Msg>
bool decodeFrom(const void* buf, std::size_t size, Msg* msg) noexcept {
  return tryDecode(buf, size, msg) == nullptr;
}

/// Initialises the lcm-gen fingerprints of every ftid_lcm type (call once, before the loop).
void warmUpCodec() noexcept;

/// Wire size of the fixed-size messages, for preallocating buffers.
int encodedSize(const ftid_lcm::cycle_sample_t&) noexcept;
int encodedSize(const ftid_lcm::compensated_wrench_t&) noexcept;
int encodedSize(const ftid_lcm::loop_stats_t&) noexcept;

}  // namespace ftid::transport
