#pragma once
// Readings the sensor did not renew (docs/log-format.md, "Held readings").
//
// A row holds a reading when its six wrench values equal the previous row's bit for bit while the
// robot's state changed (the joint angles or velocities; a pose log's pose columns). A sensor
// slower than the log's rate leaves such rows (sample-and-hold: each reading repeated until the
// next one arrives), and a stalled stream leaves long runs of them. A held row is not a new
// measurement: kept, it fakes a noise floor near zero, a strongly coloured noise and glitches at
// every renewal, and it pairs an old reading with a newer robot state. Identification and the
// laboratory keep the first row of each reading (the one the reading arrived with) and drop the
// rest; a real sensor's noise makes six bit-identical values while the arm moves impossible, so
// the rule needs no threshold. With the robot at rest too (no state change), a repeated reading is
// what a noise-free or coarsely quantized sensor gives, and it is kept.
#include <string>
#include <vector>

namespace ftid::logio {
struct LogData;
}

namespace ftid::samples {

struct HeldReadings {
  std::vector<char> held;     ///< per row of the log: 1 = holds the previous row's reading
  int count = 0;              ///< rows that hold a reading
  int runs = 0;               ///< readings held over at least one further row
  int typical_rows = 1;       ///< median, over the held readings, of the rows each one spans
  double longest_s = 0.0;     ///< the longest span [s]: from a held reading's row to the next reading's
  double longest_from_s = 0;  ///< where that span starts [s, log t]
};

/// The held rows of a measurement log (held[i] for each row; none when the log has no wrench).
HeldReadings findHeldReadings(const logio::LogData& log);

/// One line for the user: how many rows were dropped, how often each reading was repeated (the
/// sensor's rate against the log's) and the longest hold; "" when none.
std::string describeHeldReadings(const HeldReadings& h, const std::string& log_path);

}  // namespace ftid::samples
