#pragma once
// The demo cell (the README's main command): on loopback, inside a private network namespace,
// it starts the UR10 controller simulator, the CAN F/T+IMU sensor simulator carrying a payload
// with a hidden effect the paper's model lacks, and ftidd; runs `ftid --identify` with the paper
// model; lets the model laboratory name the missing effect; identifies again with it added and
// shows the held-out error fall; then streams a few seconds of live compensated wrench while the
// simulated sensor sees a push on the tool, which shows up as the only non-zero force.
#include <string>

namespace ftid::cell {

struct DemoOptions {
  std::string workdir = "out/demo";  ///< configs, logs, runs, parameters, report
  std::string hidden_effect = "temperature_drift";  ///< simulator switch the paper model lacks
  bool private_netns = true;         ///< run inside a new network namespace (LCM multicast on lo)
  int seed = 1;
};

/// Runs the demo; prints progress to stdout. Returns the process exit code.
int runDemo(const DemoOptions& options);

}  // namespace ftid::cell
