#pragma once
// The payload monitor (ftid/monitor/payload_monitor.hpp) fed by the compensator: the one way a
// compensated sample becomes a monitor sample (ftidd's monitor thread and `ftid monitor` share it),
// and the offline replay of a log through the same code (`ftid monitor --log LOG --params P.yaml`).
#include <string>
#include <vector>

#include "ftid/compensate/compensator.hpp"
#include "ftid/monitor/payload_monitor.hpp"
#include "ftid/samples/context.hpp"

namespace ftid::compensate {

/// The monitor's sample of one compensated context: its time, motion and gravity (g_S as the
/// context carries it: set it for the parameter set's tilt) and the contact wrench.
monitor::MonitorSample monitorSample(const SampleContext& ctx, const Wrench& contact_S) noexcept;

/// A replay's result.
struct MonitorReplay {
  std::vector<monitor::MonitorEvent> events;
  int n_samples = 0;          ///< samples fed to the monitor
  int n_not_compensated = 0;  ///< samples the compensator could not serve (delay line, non-finite)
  monitor::MonitorStatus final_status;
};

/// Compensates every context (in order) and feeds the monitor; t of the samples as the contexts
/// carry it (relative to the log's first sample).
MonitorReplay replayMonitor(const std::vector<SampleContext>& contexts, Compensator& compensator,
                            monitor::PayloadMonitor& monitor);

struct MonitorRequest {
  std::string log_path;
  std::string params_path;
  std::string robot_urdf;
  samples::ContextOptions context;
  monitor::MonitorSettings settings;
};

/// Reads the log and the parameter set, compensates with ftidd's compensator and replays the
/// monitor. Times in the result are the log's t (t_origin added back). Throws as
/// compensateLogFile's readers do.
MonitorReplay monitorLogFile(const MonitorRequest& request);

}  // namespace ftid::compensate
