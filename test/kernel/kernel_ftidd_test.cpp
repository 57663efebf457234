// ftidd end to end on the real kernel features of the target machine (AF_CAN, vcan0, PREEMPT_RT,
// systemd as PID 1); the second source of ftid_kernel_test (kernel_test.cpp has the kernel
// features alone). Runs only inside scripts/kernel-rig.sh (docs/kernel-rig.md); there a missing
// feature is a failure, never a skip.
//
//   FtiddOnSocketCan.*  ftid sim-robot -> ftidd <- ftid sim-sensor --can-interface vcan0, with
//                       faults scheduled in the sensor; an LCM subscriber in this process checks
//                       the rate, validity, fault flags and the compensated wrench against the
//                       simulator's truth.
//   UnderSystemd.*      stage 2 of the rig only: systemd as PID 1 runs the packaged ftidd.service
//                       unchanged (hardening, no capabilities, rlimits for real time).
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/common/status.hpp"
#include "ftid/drivers/can/ft_imu_sensor.hpp"
#include "ftid/drivers/can/socketcan.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/params/parameter_set.hpp"
#include "ftid/simrobot/sim_robot.hpp"
#include "ftid/simsensor/sim_sensor.hpp"
#include "ftid/common/records.hpp"
#include "ftid_lcm/compensated_wrench_t.hpp"
#include "ftid_lcm/loop_stats_t.hpp"
#include "kernel_test_support.hpp"
#include "test_paths.hpp"

namespace ftid {
namespace {

using kerneltest::homeQ;
using kerneltest::kIface;
using kerneltest::kSrc;
using kerneltest::requireVcan;
using kerneltest::slurp;

// Gravity in S for a robot at rest, from the UR DH forward kinematics of the robot simulator (not
// KDL, which ftidd uses) and the tilt formula of docs/conventions.md (paper Eq. 13). S = F.
Vec3 gravityInSensor(const JointVector& q, double U, double V) {
  const Vec6 pose = simrobot::forwardKinematicsTcpPose(simrobot::RobotModel::kUR10, q);
  const Vec3 rv = pose.tail<3>();
  const Mat3 R_BF = rv.norm() > 0 ? Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix()
                                  : Mat3::Identity();
  const Vec3 g_B = kStandardGravity *
                   Vec3(std::cos(U) * std::sin(V), -std::sin(U), -std::cos(U) * std::cos(V));
  return R_BF.transpose() * g_B;
}

// ---- ftidd end to end on socketcan:vcan0 -----------------------------------------------------

// The simulator's payload truth as a "paper" parameter file (what a perfect identification gives).
void writeTrueParams(const std::string& path, const sim::CellSimConfig& c) {
  const double m = c.payload.mass_kg;
  const Vec3& p = c.payload.p_SC_S;
  std::map<std::string, double> v = {
      {"mass", m},          {"mass_com_x", m * p.x()}, {"mass_com_y", m * p.y()},
      {"mass_com_z", m * p.z()}, {"f0_x", c.F0_N.x()},  {"f0_y", c.F0_N.y()},
      {"f0_z", c.F0_N.z()}, {"t0_x", c.T0_Nm.x()},     {"t0_y", c.T0_Nm.y()},
      {"t0_z", c.T0_Nm.z()}};
  const effects::Model model = effects::Model::fromName("paper");
  params::ParameterSet set;
  set.model = model.name();
  for (const auto& name : model.paramIndex().names()) set.params.push_back({name, v.at(name), 0.0, ""});
  set.tilt_estimated = true;
  set.tilt_u_rad = c.tilt_u_rad;
  set.tilt_v_rad = c.tilt_v_rad;
  params::writeParameterFile(path, set);
}

struct Received {
  std::vector<ftid_lcm::compensated_wrench_t> wrenches;
  std::vector<ftid_lcm::loop_stats_t> stats;
};

class Subscriber {
 public:
  explicit Subscriber(const std::string& url) : lcm_(url) {
    if (!lcm_.good()) throw std::runtime_error("LCM " + url + " not usable");
    lcm_.subscribe("FTID_WRENCH", &Subscriber::onWrench, this);
    lcm_.subscribe("FTID_STATS", &Subscriber::onStats, this);
    thread_ = std::thread([this] {
      while (!stop_.load()) lcm_.handleTimeout(50);
    });
  }
  ~Subscriber() { finish(); }
  Received finish() {
    if (thread_.joinable()) {
      stop_ = true;
      thread_.join();
    }
    std::lock_guard<std::mutex> lock(mutex_);
    return received_;
  }

 private:
  void onWrench(const lcm::ReceiveBuffer*, const std::string&, const ftid_lcm::compensated_wrench_t* m) {
    std::lock_guard<std::mutex> lock(mutex_);
    received_.wrenches.push_back(*m);
  }
  void onStats(const lcm::ReceiveBuffer*, const std::string&, const ftid_lcm::loop_stats_t* m) {
    std::lock_guard<std::mutex> lock(mutex_);
    received_.stats.push_back(*m);
  }
  lcm::LCM lcm_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::mutex mutex_;
  Received received_;
};

TEST(FtiddOnSocketCan, CompensatesFramesFromVcan0AndFlagsTheFaults) {
  requireVcan();
  if (HasFatalFailure()) return;
  const std::string ftid = ftid::test::binaryPath("/apps/ftid/ftid");
  const std::string ftidd = ftid::test::binaryPath("/apps/ftidd/ftidd");
  ASSERT_EQ(access(ftid.c_str(), X_OK), 0) << ftid;
  ASSERT_EQ(access(ftidd.c_str(), X_OK), 0) << ftidd;
  const std::string dir = "/tmp/ftid_kernel_e2e_" + std::to_string(getpid());
  ASSERT_EQ(std::system(("rm -rf '" + dir + "' && mkdir -p '" + dir + "'").c_str()), 0);
  const sim::CellSimConfig truth = simsensor::defaultSimSensorConfig().cell;
  writeTrueParams(dir + "/params.yaml", truth);
  const std::string url = "udpm://239.255.76.67:7667?ttl=0";
  {
    std::ofstream cfg(dir + "/ftidd.yaml");
    cfg << "robot:\n  urdf_path: " << kSrc << "/config/ur10.urdf\n"
        << "sensor:\n  transport: socketcan\n  can_interface: " << kIface
        << "\n  dbc_path: " << kSrc << "/config/ftsensor.dbc\n  stale_timeout_ms: 50\n"
        << "parameters:\n  path: " << dir << "/params.yaml\n  required: true\n"
        << "lcm:\n  url: \"" << url << "\"\n  stats_period_s: 0.5\n  publish_cycle: false\n"
        << "rt:\n  require_rt: true\n  lock_memory: true\n  priority: 80\n";
  }
  // ftidd opens socketcan:vcan0 without a peer, so it starts before the sensor: the sensor's
  // fault schedule (seconds after its first robot state) then falls inside ftidd's run.
  // The sensor runs at 125 Hz, ftidd's stale timeout is 50 ms and ftidd does not publish
  // FTID_CYCLE: qemu's TCG emulation is 10 to 50 times slower than the host (more when the host is
  // loaded), and a 1 kHz sensor cannot keep up with its own clock there.
  //   2.0 s  silent for 30 samples (240 ms > the 50 ms stale timeout)
  //   3.5 s  Fx out of range for 13 samples (104 ms)
  //   5.0 s  7 counter values skipped
  //   5.5 s  3 error frames (CAN_ERR_FLAG | CAN_ERR_CRTL)
  //   7.0 s  the sensor stops (--duration)
  std::ofstream script(dir + "/run.sh");
  script << "set -u\n"
         << "cd '" << dir << "'\n"
         << "'" << ftid << "' sim-robot > robot.log 2>&1 & R=$!\n"
         << "'" << ftidd << "' --config ftidd.yaml > ftidd.log 2>&1 & D=$!\n"
         << "i=0; until grep -q 'running at' ftidd.log; do\n"
         << "  sleep 0.2; i=$((i+1)); [ $i -gt 150 ] && { echo 'ftidd did not start'; break; }\n"
         << "  kill -0 $D 2>/dev/null || break\n"
         << "done\n"
         << "'" << ftid << "' sim-sensor --socket '" << dir << "/ft.sock' --can-interface " << kIface
         << " --urdf " << kSrc << "/config/ur10.urdf --dbc " << kSrc << "/config/ftsensor.dbc"
         << " --rate 125 --fault 2.0:silent:30 --fault 3.5:out_of_range:13"
         << " --fault 5.0:counter_gap:7 --fault 5.5:error_frame:3 --duration 7"
         << " > sensor.log 2>&1; SRC=$?\n"
         << "sleep 0.3\n"
         << "kill -TERM $D; wait $D; RC=$?\n"
         << "kill -TERM $R; wait $R\n"
         << "[ $SRC -eq 0 ] || { echo \"sim-sensor exited with $SRC\"; exit 91; }\n"
         << "exit $RC\n";
  script.close();
  Received got;
  int rc = -1;
  {
    Subscriber sub(url);
    rc = std::system(("sh '" + dir + "/run.sh'").c_str());
    got = sub.finish();
  }
  ASSERT_EQ(rc, 0) << "ftidd log:\n"
                   << slurp(dir + "/ftidd.log") << "\nsim-sensor log:\n"
                   << slurp(dir + "/sensor.log") << "\nsim-robot log:\n"
                   << slurp(dir + "/robot.log");
  const std::string ftidd_log = slurp(dir + "/ftidd.log");
  EXPECT_NE(ftidd_log.find("SCHED_FIFO 80"), std::string::npos) << ftidd_log;
  EXPECT_NE(ftidd_log.find("socketcan:vcan0"), std::string::npos) << ftidd_log;

  // The truth: the robot rests at home, so the raw reading is the payload's static load plus the
  // offsets (independent kinematics and tilt formula), and with the true parameters the contact
  // wrench is zero up to the CAN quantisation.
  const Vec3 g_S = gravityInSensor(homeQ(), truth.tilt_u_rad, truth.tilt_v_rad);
  const Vec3 f_true = truth.payload.mass_kg * g_S + truth.F0_N;
  const Vec3 t_true = truth.payload.p_SC_S.cross(truth.payload.mass_kg * g_S) + truth.T0_Nm;

  // While no robot state package arrives (qemu's TCG on a loaded host stalls the simulated
  // controller for 50-100 ms at times), ftidd publishes "silence" messages on its own clock:
  // cycle -1, valid = false, fault bit robot timeout, no contact. They are checked here and left
  // out of the per-cycle checks below (they belong to no robot cycle).
  std::vector<ftid_lcm::compensated_wrench_t> w;
  int silence = 0;
  for (const auto& m : got.wrenches) {
    if (m.cycle >= 0) {
      w.push_back(m);
      continue;
    }
    ++silence;
    EXPECT_EQ(m.cycle, -1);
    EXPECT_FALSE(m.valid) << "a silence message must be invalid";
    EXPECT_NE(static_cast<std::uint32_t>(m.fault_bits) & kFaultRobotTimeout, 0u)
        << "a silence message must name the robot timeout";
    for (int k = 0; k < 6; ++k) EXPECT_EQ(m.contact[k], 0.0) << "contact of a silence message";
  }
  std::printf("robot silence messages: %d\n", silence);
  // What happened, for the console log (no timing is asserted from it).
  std::printf("ftidd on vcan0: %zu FTID_WRENCH, %zu FTID_STATS received\n", w.size(), got.stats.size());
  if (!got.stats.empty()) {
    const auto& st = got.stats.back();
    std::printf("ftidd stats: cycles %lld missed %lld published %lld dropped %lld valid %lld "
                "invalid %lld stale %lld compute p50 %.0f us max %.0f us realtime %d\n",
                static_cast<long long>(st.cycles), static_cast<long long>(st.missed_cycles),
                static_cast<long long>(st.published), static_cast<long long>(st.publish_dropped),
                static_cast<long long>(st.valid_cycles), static_cast<long long>(st.invalid_cycles),
                static_cast<long long>(st.stale_sensor_cycles), st.compute_p50_us,
                st.compute_max_us, st.realtime ? 1 : 0);
  }
  {  // run-length trace of (valid, sensor flags, fault bits) per published cycle
    std::string trace;
    std::size_t i = 0;
    while (i < w.size()) {
      std::size_t j = i;
      while (j < w.size() && w[j].valid == w[i].valid &&
             w[j].sensor_health_flags == w[i].sensor_health_flags && w[j].fault_bits == w[i].fault_bits)
        ++j;
      char buf[96];
      std::snprintf(buf, sizeof buf, " %zux[%s f=0x%x fb=0x%x t=%.2f]", j - i, w[i].valid ? "ok" : "INV",
                    static_cast<unsigned>(w[i].sensor_health_flags),
                    static_cast<unsigned>(w[i].fault_bits), w[i].robot_time - w[0].robot_time);
      trace += buf;
      i = j;
    }
    std::printf("trace:%s\n", trace.c_str());
  }
  if (w.size() > 1) {
    std::printf("robot time span %.2f s; wall clock of the run: see the logs below on failure\n",
                w.back().robot_time - w.front().robot_time);
  }
  ASSERT_GT(w.size(), 100u) << "too few FTID_WRENCH messages\nftidd log:\n"
                            << slurp(dir + "/ftidd.log") << "\nsim-sensor log:\n"
                            << slurp(dir + "/sensor.log");
  // Sensor health bits as published (sensor_sample_t.health_flags, transport/records.hpp).
  const std::uint32_t invalidating = kHealthStale | kHealthOutOfRange | kHealthNonFinite |
                                     kHealthStatusError | kHealthTransportDown;
  int valid = 0, stale_invalid = 0, out_of_range_invalid = 0, gap_flagged = 0, error_flagged = 0;
  int unexplained_invalid = 0, flagged_valid = 0, valid_after_stale = 0, valid_after_oor = 0;
  bool seen_valid = false;
  double max_contact_err = 0.0, max_raw_err = 0.0;
  for (std::size_t i = 0; i < w.size(); ++i) {
    const auto& m = w[i];
    if (i > 0) {
      EXPECT_EQ(m.cycle, w[i - 1].cycle + 1) << "a cycle was not published";
    }
    const auto flags = static_cast<std::uint32_t>(m.sensor_health_flags);
    if (flags & kHealthCounterGap) ++gap_flagged;
    if (flags & kHealthErrorFrame) ++error_flagged;
    if (!m.valid) {
      for (int k = 0; k < 6; ++k) EXPECT_EQ(m.contact[k], 0.0) << "contact of an invalid cycle";
      // Never invalid without a reason in the message.
      if (flags == 0 && m.fault_bits == 0) ++unexplained_invalid;
      if (seen_valid && (flags & kHealthStale)) ++stale_invalid;
      if (seen_valid && (flags & kHealthOutOfRange)) ++out_of_range_invalid;
      continue;
    }
    // Never valid with a flag that invalidates the sample.
    if (flags & invalidating) ++flagged_valid;
    if (stale_invalid > 0) ++valid_after_stale;
    if (out_of_range_invalid > 0) ++valid_after_oor;
    seen_valid = true;
    ++valid;
    EXPECT_EQ(m.param_version, 1);
    for (int k = 0; k < 6; ++k) {
      EXPECT_TRUE(std::isfinite(m.contact[k]));
      max_contact_err = std::max(max_contact_err, std::abs(m.contact[k]));
    }
    for (int k = 0; k < 3; ++k) {
      max_raw_err = std::max(max_raw_err, std::abs(m.raw[k] - f_true[k]));
      max_raw_err = std::max(max_raw_err, std::abs(m.raw[3 + k] - t_true[k]) * 10.0);  // 1 Nm ~ 10 N
    }
  }
  // Validity. qemu's TCG on a loaded 2-core host is slow enough that samples also go stale and
  // counters skip outside the injected faults, so the counts are lower bounds, and each fault is
  // recognised by its own flag: stale (silence), out of range (the simulator's broken gauge),
  // counter gap, error frame.
  EXPECT_GT(valid, 25);
  EXPECT_EQ(unexplained_invalid, 0);
  EXPECT_EQ(flagged_valid, 0);
  EXPECT_GE(stale_invalid, 1) << "240 ms of silence must make cycles invalid (stale)";
  EXPECT_GE(out_of_range_invalid, 1) << "100 ms of out-of-range Fx must invalidate cycles";
  EXPECT_GT(valid_after_stale, 5) << "ftidd must recover after the silence";
  EXPECT_GT(valid_after_oor, 5) << "ftidd must recover after the out-of-range samples";
  EXPECT_GE(gap_flagged, 1) << "the silence and the skipped counters are counter gaps";
  EXPECT_GE(error_flagged, 1) << "error frames must reach ftidd";
  // Compensation against the truth.
  EXPECT_LT(max_contact_err, 0.02);
  EXPECT_LT(max_raw_err, 0.03);
  // Rate: every cycle ftidd ran was published (consecutive cycle numbers above, and as many as
  // its own count), at most one per robot packet (8 ms of controller time). Drain-to-latest skips
  // packets when the emulated machine falls behind, so the lower bound is only that the loop kept
  // up with a quarter of them; no timing is asserted.
  const double span_s = w.back().robot_time - w.front().robot_time;
  ASSERT_GT(span_s, 1.0);
  const double rate_hz = static_cast<double>(w.size() - 1) / span_s;
  std::printf("FTID_WRENCH rate %.1f per controller second (robot packets: 125)\n", rate_hz);
  EXPECT_LE(rate_hz, 125.0 * 1.01);
  EXPECT_GE(rate_hz, 125.0 * 0.25);
  // Loop statistics: published, and the loop really was real-time (SCHED_FIFO + mlockall).
  const auto at = ftidd_log.find("stopped after ");
  ASSERT_NE(at, std::string::npos) << ftidd_log;
  EXPECT_EQ(static_cast<long>(w.size()), std::atol(ftidd_log.c_str() + at + 14))
      << "the subscriber must receive every cycle ftidd ran";
  ASSERT_GE(got.stats.size(), 4u);
  for (const auto& st : got.stats) EXPECT_TRUE(st.realtime);
  EXPECT_GT(got.stats.back().stale_sensor_cycles, 0);
  if (HasFailure()) {
    std::printf("ftidd log:\n%s\nsim-sensor log:\n%s\n", slurp(dir + "/ftidd.log").c_str(),
                slurp(dir + "/sensor.log").c_str());
  }
  std::system(("rm -rf '" + dir + "'").c_str());  // the VM's tmpfs: the logs are printed above
}

// ---- the packaged unit under systemd (stage 2 of the rig) -------------------------------------
// scripts/kernel-rig.sh switches the VM to a tmpfs root with systemd as PID 1 and lays the files
// out as the .deb installs them; rig_systemd_checks.sh has run systemd-sysusers and the postinst
// (the ftid user, /etc/ftid/command.key). This test then starts debian/ftid.ftidd.service
// unchanged, with every hardening option, and checks what the unit's comments promise: the loop
// thread gets SCHED_FIFO through LimitRTPRIO and memory is locked through LimitMEMLOCK with no
// capability at all, as the ftid user; sd_notify readiness and the 2 s watchdog (the run lasts
// longer); LCM multicast on loopback passes IPAddressAllow; SIGHUP reloads; stop ends cleanly.

std::string capture(const std::string& cmd) {
  std::string out;
  if (FILE* p = ::popen((cmd + " 2>&1").c_str(), "r")) {
    char buf[512];
    while (std::fgets(buf, sizeof buf, p)) out += buf;
    ::pclose(p);
  }
  return out;
}

std::string showProperty(const std::string& unit, const std::string& prop) {
  std::string v = capture("systemctl show -p " + prop + " --value " + unit);
  while (!v.empty() && (v.back() == '\n' || v.back() == ' ')) v.pop_back();
  return v;
}

/// The value of a "Key:\tvalue" line of /proc/PID/status ("" if missing).
std::string procStatus(long pid, const std::string& key) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key + ":", 0) == 0) {
      std::string v = line.substr(key.size() + 1);
      v.erase(0, v.find_first_not_of(" \t"));
      return v;
    }
  }
  return "";
}

TEST(UnderSystemd, PackagedUnitRunsRealTimeWithoutCapabilitiesPublishesReloadsAndStops) {
  ASSERT_EQ(slurp("/proc/1/comm"), "systemd\n")
      << "runs only in stage 2 of scripts/kernel-rig.sh (systemd as PID 1)";
  requireVcan();
  if (HasFatalFailure()) return;
  const std::string ftid = ftid::test::binaryPath("/apps/ftid/ftid");
  ASSERT_EQ(access("/usr/sbin/ftidd", X_OK), 0);
  ASSERT_EQ(access("/lib/systemd/system/ftidd.service", R_OK), 0);
  const std::string url = "udpm://239.255.76.67:7667?ttl=0";
  const sim::CellSimConfig truth = simsensor::defaultSimSensorConfig().cell;
  ASSERT_EQ(std::system("mkdir -p /var/lib/ftid /etc/ftid"), 0);
  writeTrueParams("/var/lib/ftid/parameters.yaml", truth);
  {
    std::ofstream cfg("/etc/ftid/ftidd.yaml");
    cfg << "robot:\n  host: 127.0.0.1\n  urdf_path: /usr/share/ftid/config/ur10.urdf\n"
        << "sensor:\n  transport: socketcan\n  can_interface: " << kIface
        << "\n  dbc_path: /usr/share/ftid/config/ftsensor.dbc\n  stale_timeout_ms: 50\n"
        << "parameters:\n  path: /var/lib/ftid/parameters.yaml\n  required: true\n"
        << "lcm:\n  url: \"" << url << "\"\n  stats_period_s: 0.5\n  publish_cycle: false\n"
        << "  command_key_path: /etc/ftid/command.key\n"
        << "rt:\n  require_rt: true\n  lock_memory: true\n  priority: 80\n";
  }
  const std::string dir = "/tmp/ftid_systemd_" + std::to_string(getpid());
  ASSERT_EQ(std::system(("mkdir -p '" + dir + "'").c_str()), 0);
  ASSERT_EQ(std::system(("cd '" + dir + "' && '" + ftid + "' sim-robot > robot.log 2>&1 & echo $! > '" +
                         dir + "/robot.pid'")
                            .c_str()),
            0);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const auto journal = [] { return capture("journalctl -u ftidd --no-pager -o cat | tail -n 60"); };

  Received got;
  long pid = 0;
  std::string vmlck, cap_eff, uid, fifo_threads;
  int fifo_prio = -1;
  std::string pid_after_reload, reload_rc, stop_rc, result, nrestarts, exec_status;
  {
    Subscriber sub(url);
    // Type=notify: start returns when ftidd sent READY=1 (or failed).
    const int start_rc = std::system("timeout 120 systemctl start ftidd");
    ASSERT_EQ(start_rc, 0) << "systemctl start ftidd failed\n"
                           << capture("systemctl status ftidd --no-pager") << journal();
    pid = std::atol(showProperty("ftidd", "MainPID").c_str());
    ASSERT_GT(pid, 1);
    // The sensor streams for 6 s: three watchdog periods (WatchdogSec=2s), with a reload inside.
    const std::string sensor = "cd '" + dir + "' && '" + ftid + "' sim-sensor --socket '" + dir +
                               "/ft.sock' --can-interface " + kIface +
                               " --urdf /usr/share/ftid/config/ur10.urdf"
                               " --dbc /usr/share/ftid/config/ftsensor.dbc --rate 125 --duration 6"
                               " > sensor.log 2>&1";
    std::thread sensor_thread([&] { std::system(sensor.c_str()); });
    std::this_thread::sleep_for(std::chrono::seconds(2));
    vmlck = procStatus(pid, "VmLck");
    cap_eff = procStatus(pid, "CapEff");
    uid = procStatus(pid, "Uid");
    {
      const std::string tasks = capture("ls /proc/" + std::to_string(pid) + "/task");
      std::istringstream ts(tasks);
      long tid = 0;
      while (ts >> tid) {
        if (::sched_getscheduler(static_cast<pid_t>(tid)) == SCHED_FIFO) {
          sched_param sp{};
          ::sched_getparam(static_cast<pid_t>(tid), &sp);
          fifo_prio = sp.sched_priority;
          fifo_threads += std::to_string(tid) + " ";
        }
      }
    }
    reload_rc = std::to_string(std::system("systemctl reload ftidd"));
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    pid_after_reload = showProperty("ftidd", "MainPID");
    sensor_thread.join();
    nrestarts = showProperty("ftidd", "NRestarts");
    stop_rc = std::to_string(std::system("timeout 60 systemctl stop ftidd"));
    result = showProperty("ftidd", "Result");
    exec_status = showProperty("ftidd", "ExecMainStatus");
    got = sub.finish();
  }
  std::system(("kill -TERM $(cat '" + dir + "/robot.pid')").c_str());
  const std::string log = journal();

  // Real time through the rlimits, without capabilities, as the ftid user.
  EXPECT_NE(vmlck, "") << "no VmLck line for PID " << pid;
  EXPECT_GT(std::atol(vmlck.c_str()), 0) << "memory not locked (VmLck " << vmlck << ")\n" << log;
  EXPECT_EQ(cap_eff, "0000000000000000") << "the unit grants no capability";
  EXPECT_NE(uid.rfind("0\t", 0), 0u) << "ftidd must not run as root (Uid: " << uid << ")";
  EXPECT_FALSE(fifo_threads.empty()) << "no SCHED_FIFO thread in ftidd\n" << log;
  EXPECT_EQ(fifo_prio, 80);
  // The loop reported real time in its statistics, and said why if something was missing.
  ASSERT_FALSE(got.stats.empty()) << "no FTID_STATS from the unit (IPAddressAllow?)\n" << log;
  for (const auto& st : got.stats) EXPECT_TRUE(st.realtime);
  // Watchdog (2 s) fed through a 6 s run, reload by SIGHUP in place, clean stop.
  EXPECT_EQ(reload_rc, "0");
  EXPECT_EQ(pid_after_reload, std::to_string(pid)) << "the reload must not restart the process";
  EXPECT_EQ(nrestarts, "0") << log;
  EXPECT_EQ(stop_rc, "0");
  EXPECT_EQ(result, "success") << log;
  EXPECT_EQ(exec_status, "0") << log;
  // Compensated wrenches reached a subscriber outside the unit, against the simulator's truth.
  int valid = 0;
  double max_contact = 0.0;
  for (const auto& m : got.wrenches) {
    if (!m.valid) continue;
    ++valid;
    for (int k = 0; k < 6; ++k) max_contact = std::max(max_contact, std::abs(m.contact[k]));
  }
  std::printf("under systemd: %zu FTID_WRENCH (%d valid), %zu FTID_STATS, SCHED_FIFO threads %s, "
              "VmLck %s\n",
              got.wrenches.size(), valid, got.stats.size(), fifo_threads.c_str(), vmlck.c_str());
  // qemu's TCG on a loaded host lets many sensor samples go stale (50 ms timeout), so only a
  // handful of valid cycles is required; each one is checked against the truth.
  EXPECT_GT(valid, 10) << log;
  EXPECT_LT(max_contact, 0.02) << "the true parameters must compensate the resting tool";
  if (HasFailure()) {
    std::printf("ftidd journal:\n%s\nsim-sensor log:\n%s\nsim-robot log:\n%s\n", log.c_str(),
                slurp(dir + "/sensor.log").c_str(), slurp(dir + "/robot.log").c_str());
  }
}

}  // namespace
}  // namespace ftid
