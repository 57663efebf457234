// Fuzz target: the readers of other recordings (docs/log-format.md): the CDR decoders of ROS 2
// bags' JointState and WrenchStamped messages, and the numeric table reader with the UR RTDE
// recording and wrench-log conversions on top. The first byte picks the reader.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "ftid/common/error.hpp"
#include "ftid/logio/cdr.hpp"
#include "ftid/logio/input.hpp"
#include "ftid/logio/table.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::uint8_t mode = data[0] % 3;
  const std::uint8_t* body = data + 1;
  const std::size_t n = size - 1;
  try {
    if (mode == 0) {
      const ftid::logio::JointStateMsg m = ftid::logio::decodeJointState(body, n);
      if (m.name.size() > ftid::logio::kMaxJointNames || m.frame_id.size() > ftid::logio::kMaxCdrStringBytes) {
        __builtin_trap();
      }
    } else if (mode == 1) {
      (void)ftid::logio::decodeWrenchStamped(body, n);
    } else {
      const std::string_view text(reinterpret_cast<const char*>(body), n);
      const ftid::logio::Table table = ftid::logio::parseTable(text, "fuzz.txt");
      for (const auto& c : table.columns) {
        if (c.size() != table.rows()) __builtin_trap();
        for (const double v : c) {
          if (!std::isfinite(v)) __builtin_trap();
        }
      }
      try {
        const ftid::logio::InputLog in = ftid::logio::urRecordToLog(table, {});
        for (std::size_t i = 1; i < in.log.samples.size(); ++i) {
          if (!(in.log.samples[i].t > in.log.samples[i - 1].t) || !in.log.samples[i].qdd.allFinite()) __builtin_trap();
        }
      } catch (const ftid::Error&) {
      }
      const ftid::logio::LogData w = ftid::logio::wrenchLogFromTable(table);
      for (std::size_t i = 1; i < w.samples.size(); ++i) {
        if (!(w.samples[i].t > w.samples[i - 1].t)) __builtin_trap();
      }
    }
  } catch (const ftid::Error&) {
    // a clear rejection
  }
  return 0;
}
