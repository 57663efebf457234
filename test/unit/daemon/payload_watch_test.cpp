// ftidd's payload monitor thread (PayloadWatch), driven by poll() without the thread: the same
// decisions as the offline replay of the same samples, the flags, the report rate, the reset on a
// new parameter version, and the LCM message.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "../monitor/monitor_cell.hpp"
#include "ftid/common/error.hpp"
#include "ftid/common/status.hpp"
#include "ftid/daemon/payload_watch.hpp"
#include "ftid_lcm/payload_monitor_t.hpp"

namespace ftid::daemon {
namespace {

struct Recorded {
  std::vector<MonitorInput> inputs;
  compensate::MonitorReplay offline;
};

// A grasp of 0.6 kg at 5 s, compensated with payload A; the samples and the offline replay.
Recorded graspRun() {
  static const test::IdentifiedCell cell(11);
  sim::CellSimConfig cfg = test::operationRun(5101, 12101, 8.0);
  cfg.payload_change.enabled = true;
  cfg.payload_change.t_s = 5.0;
  cfg.payload_change.added = sim::compactObject(0.6, Vec3(0.01, 0.0, 0.1));
  const logio::LogData log = sim::CellSim(cfg).run();
  samples::ContextSet contexts = samples::buildContexts(log, *cfg.robot);
  samples::setTilt(contexts.samples, cell.nonlinear.tilt_u_rad, cell.nonlinear.tilt_v_rad);
  Recorded r;
  compensate::Compensator comp(cell.model, cell.theta, cell.nonlinear);
  for (const auto& ctx : contexts.samples) {
    Wrench contact;
    if (comp.compute(ctx, &contact, nullptr) == Status::kOk) {
      r.inputs.push_back(MonitorInput{compensate::monitorSample(ctx, contact), 1});
    }
  }
  compensate::Compensator comp2(cell.model, cell.theta, cell.nonlinear);
  monitor::PayloadMonitor mon{monitor::MonitorSettings{}};
  r.offline = compensate::replayMonitor(contexts.samples, comp2, mon);
  return r;
}

TEST(PayloadWatch, DecidesAsTheOfflineReplayAndFlagsAndReports) {
  const Recorded run = graspRun();
  ASSERT_EQ(run.offline.events.size(), 1u);
  MonitorLink link;
  std::vector<MonitorReport> reports;
  PayloadWatch watch(monitor::MonitorSettings{}, 4.0, &link, [&](const MonitorReport& r) { reports.push_back(r); });
  std::uint32_t flags_before = 0;
  std::int64_t now_us = 1'000'000;
  for (std::size_t i = 0; i < run.inputs.size(); ++i) {
    link.handOver(run.inputs[i]);
    if (i % 10 == 9) {  // the thread wakes every 10 ms; 10 samples are 80 ms
      now_us += 80'000;
      watch.poll(now_us, now_us);
      if (run.inputs[i].sample.t < 4.9) flags_before |= link.flags();
    }
  }
  now_us += 80'000;
  watch.poll(now_us, now_us);
  EXPECT_EQ(flags_before, 0u);
  EXPECT_EQ(link.flags(), static_cast<std::uint32_t>(kFlagPayloadChanged));
  EXPECT_EQ(link.dropped.load(), 0u);
  int events = 0, periodic = 0;
  for (const MonitorReport& r : reports) {
    if (!r.event) {
      ++periodic;
      continue;
    }
    ++events;
    // Online equals offline, bit for bit (same code, same samples).
    EXPECT_EQ(r.event->t_decided, run.offline.events[0].t_decided);
    EXPECT_EQ(r.event->change.delta_mass_kg, run.offline.events[0].change.delta_mass_kg);
    EXPECT_NEAR(r.event->change.delta_mass_kg, 0.6, 0.06);
  }
  EXPECT_EQ(events, 1);
  const double span_s = static_cast<double>(now_us - 1'000'000) * 1e-6;
  EXPECT_GE(periodic, static_cast<int>(2.0 * span_s));  // at least 2 Hz (4 Hz configured)
  EXPECT_LE(periodic, static_cast<int>(4.0 * span_s) + 1);

  // New parameters (e.g. after re-identification): the monitor starts over.
  MonitorInput next = run.inputs.back();
  next.sample.t += 0.008;
  next.sample.residual_S.setZero();
  next.param_version = 2;
  link.handOver(next);
  watch.poll(now_us + 10'000, now_us + 10'000);
  EXPECT_EQ(link.flags(), 0u);
  EXPECT_EQ(watch.latest().status.state, monitor::MonitorState::kOk);
}

// The periodic report is timed on the monotonic clock: the real-time clock set back by an hour
// (NTP, an operator) does not silence it, and the reports keep the real-time clock's utime.
TEST(PayloadWatch, ARealtimeClockStepDoesNotSilenceThePeriodicReports) {
  MonitorLink link;
  std::vector<MonitorReport> reports;
  PayloadWatch watch(monitor::MonitorSettings{}, 4.0, &link,
                     [&](const MonitorReport& r) { reports.push_back(r); });
  std::int64_t real_us = 1'700'000'000'000'000, mono_us = 9'000'000'000;
  for (int k = 0; k < 200; ++k) {  // 2 s in 10 ms polls; the real-time clock steps back at 1 s
    if (k == 100) real_us -= 3'600'000'000;
    watch.poll(real_us, mono_us);
    real_us += 10'000;
    mono_us += 10'000;
  }
  int after_step = 0;
  for (const MonitorReport& r : reports) after_step += r.utime < 1'700'000'000'000'000 ? 1 : 0;
  EXPECT_GE(reports.size(), 8u);  // 4 Hz over 2 s
  EXPECT_LE(reports.size(), 9u);
  EXPECT_GE(after_step, 4);       // and as many in the second after the step
}

TEST(PayloadWatch, MessageCarriesVersionStateAndEstimate) {
  MonitorReport r;
  r.status.state = monitor::MonitorState::kChanged;
  r.status.change.delta_mass_kg = 0.5;
  r.status.change.delta_mass_std_kg = 0.01;
  r.status.change.delta_com_m = Vec3(0.1, 0.2, 0.3);
  r.param_version = 7;
  monitor::MonitorEvent e;
  e.kind = monitor::EventKind::kPayloadChange;
  e.t_decided = 5.5;
  e.change = r.status.change;
  r.event = e;
  const ftid_lcm::payload_monitor_t m = toMessage(r);
  EXPECT_EQ(m.version, 1);
  EXPECT_EQ(m.state, ftid_lcm::payload_monitor_t::STATE_CHANGED);
  EXPECT_EQ(m.event_kind, ftid_lcm::payload_monitor_t::EVENT_PAYLOAD_CHANGE);
  EXPECT_EQ(m.event_t, 5.5);
  EXPECT_EQ(m.delta_mass, 0.5);
  EXPECT_EQ(m.delta_com[2], 0.3);
  EXPECT_EQ(m.param_version, 7);
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  ASSERT_GT(m.encode(buf.data(), 0, static_cast<int>(buf.size())), 0);
  ftid_lcm::payload_monitor_t back;
  ASSERT_GT(back.decode(buf.data(), 0, static_cast<int>(buf.size())), 0);
  EXPECT_EQ(back.delta_mass, 0.5);
}

}  // namespace
}  // namespace ftid::daemon

namespace ftid::daemon {
namespace {

TEST(PayloadWatch, RecentKeepsTheNewestVersionWithinTheWindow) {
  MonitorLink link;
  PayloadWatch watch(monitor::MonitorSettings{}, 4.0, &link, {}, 100);
  EXPECT_TRUE(watch.recent(4.0).empty());
  for (int k = 0; k < 300; ++k) {
    MonitorInput in;
    in.sample.t = 0.01 * k;
    in.param_version = k < 250 ? 1 : 2;
    link.handOver(in);
  }
  watch.poll(1, 1);
  const auto last = watch.recent(10.0);
  ASSERT_EQ(last.size(), 50u);  // version 2 only
  EXPECT_DOUBLE_EQ(last.front().t, 2.5);
  EXPECT_DOUBLE_EQ(last.back().t, 2.99);
  EXPECT_EQ(watch.recent(0.095).size(), 10u);
}

TEST(PayloadWatch, ReidentifiedSetAddsTheChange) {
  params::ParameterSet set;
  set.model = "paper";
  set.params = {{"mass", 1.0, 0.01, "kg"}, {"mass_com_x", 0.0, 0.0, "kg*m"}, {"mass_com_y", 0.01, 0.0, "kg*m"},
                {"mass_com_z", 0.05, 0.0, "kg*m"}, {"f0_x", 0.3, 0.0, "N"}};
  const monitor::ChangeVector p = payloadOf(set);
  EXPECT_EQ(p[0], 1.0);
  EXPECT_TRUE(std::isnan(p[4]));  // no inertia in this model
  monitor::ChangeFit fit;
  fit.change.delta << 0.6, 0.006, 0.0, 0.06, 0, 0, 0, 0, 0, 0;
  fit.change.covariance = monitor::ChangeMatrix::Identity() * 1e-6;
  const params::ParameterSet next = reidentifiedSet(set, fit);
  EXPECT_DOUBLE_EQ(next.params[0].value, 1.6);
  EXPECT_DOUBLE_EQ(next.params[1].value, 0.006);
  EXPECT_DOUBLE_EQ(next.params[3].value, 0.11);
  EXPECT_DOUBLE_EQ(next.params[4].value, 0.3);  // offsets kept
  EXPECT_DOUBLE_EQ(next.params[0].std, 1e-3);
  params::ParameterSet no_mass;
  no_mass.model = "offsets";
  no_mass.params = {{"f0_x", 0.3, 0.0, "N"}};
  EXPECT_THROW(payloadOf(no_mass), ConfigError);
}

}  // namespace
}  // namespace ftid::daemon
