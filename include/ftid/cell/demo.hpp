#pragma once
// The demo cell (the README's main command): on loopback, inside a private network namespace,
// it starts the UR10 controller simulator, the CAN F/T+IMU sensor simulator carrying a payload
// with a hidden effect the paper's model lacks, and ftidd; runs `ftid --identify` with the paper
// model; lets the model laboratory name the missing effect; identifies again with it added and
// shows the held-out error fall; then streams a few seconds of live compensated wrench while the
// simulated sensor sees a push on the tool, which shows up as the only non-zero force.
#include <cstdint>
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

/// `ftid demo --offline`: the paper only, no processes. Simulates a 10 s paper-style excitation of
/// a UR10 carrying the paper's payload (0.05 N / 0.01 Nm noise, `seed`), identifies the 12
/// parameters with the paper's dynamic method, prints them beside the truth (error in standard
/// errors) and the RMS of an independent run (seed + 1000) before and after compensation.
struct OfflineDemoOptions {
  std::uint64_t seed = 1;
  std::string robot_urdf;     ///< empty: the shipped ur10.urdf
  bool full_physics = false;  ///< simulate full rigid-body physics (the paper's model lacks it)
};
int runOfflineDemo(const OfflineDemoOptions& options);

}  // namespace ftid::cell
