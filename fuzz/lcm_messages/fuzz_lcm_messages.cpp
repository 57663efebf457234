// Fuzz target: the decode path of every LCM type ftid receives (issue 26). The first byte picks
// the type, the rest is the datagram's payload, fed to transport::tryDecode: the one decode used
// by ftidd's command subscription (command_t), `ftid tare`'s and --identify's ack waiter (ack_t),
// the cell's cycle recorder and the demo's collector (cycle_sample_t, compensated_wrench_t),
// lcm-to-csv, and the other types. Checked: tryDecode never throws; whenever its wire walk
// (findWireProblem) passes, lcm-gen's own decoder, called here unguarded, does not throw either
// (an escaped std::length_error is reported by libFuzzer); and whatever is accepted re-encodes
// to exactly the received bytes.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "ftid/transport/codec.hpp"

namespace {

template <class Msg>
void check(const std::uint8_t* data, std::size_t size) {
  Msg msg{};
  const char* problem = ftid::transport::tryDecode(data, size, &msg);
  if (size > 0 && ftid::transport::findWireProblem(data, size, static_cast<const Msg*>(nullptr)) == nullptr) {
    Msg raw{};
    (void)raw.decode(data, 0, static_cast<int>(size));  // must not throw
  }
  if (problem != nullptr) return;
  std::vector<std::uint8_t> again(static_cast<std::size_t>(msg.getEncodedSize()));
  const int n = msg.encode(again.data(), 0, static_cast<int>(again.size()));
  if (n != static_cast<int>(size) || std::memcmp(again.data(), data, size) != 0) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t* p = data + 1;
  const std::size_t n = size - 1;
  switch (data[0] % 8) {
    case 0: check<ftid_lcm::command_t>(p, n); break;
    case 1: check<ftid_lcm::ack_t>(p, n); break;
    case 2: check<ftid_lcm::identification_result_t>(p, n); break;
    case 3: check<ftid_lcm::cycle_sample_t>(p, n); break;
    case 4: check<ftid_lcm::compensated_wrench_t>(p, n); break;
    case 5: check<ftid_lcm::loop_stats_t>(p, n); break;
    case 6: check<ftid_lcm::robot_state_t>(p, n); break;
    default: check<ftid_lcm::sensor_sample_t>(p, n); break;
  }
  return 0;
}
