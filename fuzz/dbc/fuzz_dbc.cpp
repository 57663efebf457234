// Fuzz target: the DBC parser (ftid::drivers::can::parseDbc) and the sensor layout built from it.
#include <cstddef>
#include <cstdint>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/drivers/can/dbc.hpp"
#include "ftid/drivers/can/sensor_layout.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const ftid::drivers::can::DbcDatabase db = ftid::drivers::can::parseDbc(text, "fuzz.dbc");
    (void)ftid::drivers::can::SensorLayout::fromDbc(db);
  } catch (const ftid::Error&) {
    // a clear rejection naming file and line
  }
  return 0;
}
