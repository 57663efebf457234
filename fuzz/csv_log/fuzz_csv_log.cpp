// Fuzz target: the CSV log reader (ftid::logio::parseLogText, the body of readLog).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "ftid/common/error.hpp"
#include "ftid/logio/log.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  for (const auto kind : {ftid::logio::LogKind::kMeasurement, ftid::logio::LogKind::kTrajectory}) {
    try {
      const ftid::logio::LogData log = ftid::logio::parseLogText(text, "fuzz.csv", kind);
      // Whatever is accepted is finite, within range and strictly increasing in t.
      for (std::size_t i = 0; i < log.samples.size(); ++i) {
        const auto& s = log.samples[i];
        if (!s.q.allFinite() || !s.wrench_S.allFinite() || s.q.cwiseAbs().maxCoeff() > 12.6) __builtin_trap();
        if (i > 0 && !(s.t > log.samples[i - 1].t)) __builtin_trap();
      }
      for (const auto& column : log.extra_columns) {
        if (column.size() != log.samples.size()) __builtin_trap();
      }
    } catch (const ftid::Error&) {
      // a clear rejection naming file, line and column
    }
  }
  return 0;
}
