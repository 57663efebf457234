// Fuzz target: trajectory files (ftid::trajectory::parseTrajectoryText, the body of
// readTrajectoryFile), then evaluation of what was accepted.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/trajectory/trajectory_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const ftid::trajectory::TrajectoryFile file = ftid::trajectory::parseTrajectoryText(text, "fuzz.yaml");
    const auto traj = file.toTrajectory();
    const double d = traj.duration();
    for (int i = 0; i <= 4; ++i) (void)traj.evaluate(0.25 * i * (std::isfinite(d) ? d : 0.0));
  } catch (const ftid::Error&) {
    // a clear rejection naming file, line and key
  }
  return 0;
}
