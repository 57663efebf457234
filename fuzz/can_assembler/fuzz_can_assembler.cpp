// Fuzz target: the CAN sample assembler (ftid::drivers::can::SampleAssembler) fed arbitrary frames: ids,
// lengths, payloads, flags and receive times chosen by the fuzzer, with the shipped DBC's layout.
// Each 16-byte record is one frame: can_id (4), dlc (1), flags (1), dt_us (2), data (8).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>

#include "ftid/drivers/can/dbc.hpp"
#include "ftid/drivers/can/sensor_layout.hpp"
#include "ftid/drivers/can/transport.hpp"
#include "test_paths.hpp"

namespace {
const ftid::drivers::can::SensorLayout& layout() {
  static const ftid::drivers::can::SensorLayout l =
      ftid::drivers::can::SensorLayout::fromDbc(ftid::drivers::can::loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc")));
  return l;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  ftid::drivers::can::SensorHealthOptions options;
  options.counter_gap_invalidates = (data[0] & 1) != 0;
  options.error_frame_invalidates = (data[0] & 2) != 0;
  options.max_open_groups = 1 + (data[0] >> 4);
  ftid::drivers::can::SampleAssembler assembler(layout(), options);
  std::int64_t t_ns = 1'000'000'000;
  ftid::drivers::can::SensorSample out;
  for (std::size_t pos = 1; pos + 16 <= size; pos += 16) {
    const std::uint8_t* r = data + pos;
    ftid::drivers::can::ReceivedFrame f;
    std::memcpy(&f.frame.can_id, r, 4);
    f.frame.len = r[4];  // deliberately unchecked: may exceed 8
    f.frame.__pad = r[5];
    std::memcpy(f.frame.data, r + 8, 8);
    t_ns += (std::int64_t{r[6]} << 8 | r[7]) * 1000;
    f.rx_time_ns = t_ns;
    if (assembler.feed(f)) {
      const auto& s = assembler.latest();
      if (s.valid && !s.wrench_S.allFinite()) __builtin_trap();
    }
    if (r[5] & 0x80) assembler.noteTransportProblem();
    assembler.readLatest(out, t_ns);
    if (out.valid && !out.wrench_S.allFinite()) __builtin_trap();
  }
  return 0;
}
