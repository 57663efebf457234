// The payload monitor fed by the compensator (include/ftid/compensate/monitor_log.hpp).
#include "ftid/compensate/monitor_log.hpp"

#include "ftid/effects/model.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::compensate {

monitor::MonitorSample monitorSample(const SampleContext& ctx, const Wrench& contact_S) noexcept {
  monitor::MonitorSample s;
  s.t = ctx.t;
  s.g_S = ctx.g_S;
  s.a_S = ctx.a_S;
  s.w_S = ctx.w_S;
  s.alpha_S = ctx.alpha_S;
  s.residual_S = contact_S;
  return s;
}

MonitorReplay replayMonitor(const std::vector<SampleContext>& contexts, Compensator& compensator,
                            monitor::PayloadMonitor& monitor) {
  MonitorReplay replay;
  for (const SampleContext& ctx : contexts) {
    Wrench contact;
    if (compensator.compute(ctx, &contact, nullptr) != Status::kOk) {
      ++replay.n_not_compensated;
      continue;
    }
    ++replay.n_samples;
    if (auto event = monitor.update(monitorSample(ctx, contact))) replay.events.push_back(*event);
  }
  replay.final_status = monitor.status();
  return replay;
}

MonitorReplay monitorLogFile(const MonitorRequest& request) {
  const params::ParameterSet set = params::readParameterFile(request.params_path);
  const effects::Model model = effects::Model::fromName(set.model);
  const Eigen::VectorXd theta = params::thetaFor(model, set, request.params_path);
  const effects::NonlinearParams nonlinear = params::nonlinearFor(model, set, request.params_path);
  samples::ContextOptions context = request.context;
  context.time_origin_unix_s = set.time_origin_unix_s;
  context.tilt_u_rad = nonlinear.tilt_u_rad;  // g_S of the monitor's samples as the compensator sees it
  context.tilt_v_rad = nonlinear.tilt_v_rad;
  const samples::ContextSet contexts = samples::loadLogContexts(request.log_path, request.robot_urdf, context);
  Compensator compensator(model, theta, nonlinear);
  monitor::PayloadMonitor monitor(request.settings);
  MonitorReplay replay = replayMonitor(contexts.samples, compensator, monitor);
  for (monitor::MonitorEvent& e : replay.events) {
    e.t_onset += contexts.t_origin;
    e.t_decided += contexts.t_origin;
  }
  replay.final_status.t += contexts.t_origin;
  replay.final_status.onset_t += contexts.t_origin;
  return replay;
}

}  // namespace ftid::compensate
