#pragma once
// ftidd configuration: plain structs with defaults, loaded and validated once at start-up by
// loadDaemonConfig() and never read again inside the loop. The YAML keys are the member names
// grouped by section (e.g. `robot.rtde_frequency_hz`); config/ftidd.yaml documents every key.
// Relative paths in a config file are resolved against the directory of that file.
#include <chrono>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"

namespace ftid::config {

struct RobotConfig {
  std::string host = "127.0.0.1";      ///< UR controller address (RTDE and dashboard)
  int rtde_port = 30004;               ///< RTDE port
  int dashboard_port = 29999;          ///< dashboard server port (status queries only)
  double rtde_frequency_hz = 125.0;    ///< RTDE output frequency (CB3: 125, e-Series: <= 500)
  /// The robot's rated payload [kg] (UR10 10, UR10e 12.5): a parameter set with a larger mass is
  /// refused (params::PlausibilityLimits; ftidd start and reload, ftid compensate and identify).
  double rated_payload_kg = 10.0;
  std::string urdf_path = "/usr/share/ftid/config/ur10.urdf";  ///< robot model (must exist)
  std::string base_link = "base";      ///< URDF base link (frame B)
  std::string tip_link = "tool0";      ///< URDF flange link (frame F)
  /// A cycle is missed if no state packet arrives within this time; 0 = 1.5 RTDE periods.
  double receive_timeout_ms = 0.0;
  /// Without a state package for this long ftidd publishes valid = false (20 Hz) [ms].
  double silent_publish_after_ms = 50.0;
  /// Without a robot link (no state package) for this long ftidd stops feeding the systemd
  /// watchdog, so systemd restarts it [s]; 0 = never (ftidd reconnects in-process; the watchdog
  /// still ends a wedged process). docs/operations.md, "Link loss and reconnect".
  double watchdog_silence_s = 0.0;
  /// Without a state package for this long while the TCP connection stays up, the link is
  /// declared dead and ftidd reconnects [s]; 0 = only when TCP reports it dead (keepalive).
  double reconnect_after_silence_s = 5.0;
  /// Reconnect backoff: the first retry after reconnect_backoff_min_s, then doubling, never more
  /// than reconnect_backoff_max_s between attempts [s] (also the connection attempts at start).
  double reconnect_backoff_min_s = 0.2;
  double reconnect_backoff_max_s = 5.0;

  /// The effective receive timeout.
  std::chrono::microseconds receiveTimeout() const {
    const double ms = receive_timeout_ms > 0.0 ? receive_timeout_ms : 1500.0 / rtde_frequency_hz;
    return std::chrono::microseconds(static_cast<long long>(ms * 1000.0));
  }
};

struct SensorConfig {
  /// "seqpacket": CAN frames over a Unix SOCK_SEQPACKET socket (ftid sim-sensor, kernels without
  /// AF_CAN); "socketcan": a SocketCAN interface.
  std::string transport = "seqpacket";
  std::string socket_path = "/run/ftid/ftsensor.sock";  ///< for transport seqpacket
  std::string can_interface = "can0";                 ///< for transport socketcan
  std::string dbc_path = "/usr/share/ftid/config/ftsensor.dbc";  ///< frame layout (must exist)
  /// A sample older than this (no new frame) is stale: flagged, never compensated as valid.
  double stale_timeout_ms = 20.0;
  /// Sensor mount X_FS: position of S in the flange frame F [m] and orientation as roll, pitch,
  /// yaw [rad] (R_FS = Rz(yaw) * Ry(pitch) * Rx(roll), as in URDF).
  Vec3 mount_xyz = Vec3::Zero();
  Vec3 mount_rpy = Vec3::Zero();
  /// Where compensation takes the sensor's acceleration and angular motion from: "kinematics"
  /// (the joints through the robot model) or "imu" (the sensor's IMU, less the parameter file's
  /// `imu` biases; a cycle without an IMU sample is then invalid). docs/effects.md "Motion from the IMU".
  std::string motion_source = "kinematics";

  Mat3 R_FS() const;
  Vec3 p_FS_F() const { return mount_xyz; }
};

struct ParametersConfig {
  /// Payload parameter file written by `ftid --identify` (reloaded on SIGHUP).
  std::string path = "/var/lib/ftid/parameters.yaml";
  /// If true, ftidd refuses to start without a valid parameter file; if false it starts and
  /// publishes the raw wrench with valid = false until parameters are loaded.
  bool required = false;
  /// TARE command (docs/daemon.md, "Tare"): averaging window [s], and the joint speed
  /// [rad/s] and acceleration [rad/s^2] above which the robot counts as moving (tare refused).
  double tare_window_s = 0.25;
  double tare_max_qd = 0.01;
  double tare_max_qdd = 0.2;
};

struct LcmChannels {
  std::string cycle = "FTID_CYCLE";
  std::string wrench = "FTID_WRENCH";
  std::string stats = "FTID_STATS";
  std::string command = "FTID_COMMAND";
  std::string ack = "FTID_ACK";
};

struct LcmConfig {
  /// LCM provider URL. Default: UDP multicast that never leaves this host (ttl=0).
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  LcmChannels channels;
  bool publish_cycle = true;  ///< publish cycle_sample_t (raw synchronised data)
  double stats_period_s = 1.0;  ///< loop_stats_t period
  /// Shared HMAC key for command_t (ftid/transport/command_auth.hpp); hex, mode 0640.
  std::string command_key_path = "/etc/ftid/command.key";
  /// false: receive LCM datagrams only from this host (kernel socket filter on the source address).
  bool accept_remote = false;
};

struct RtConfig {
  /// If true, failure to get SCHED_FIFO / locked memory / CPU affinity stops ftidd;
  /// if false it warns, reports realtime = false and continues.
  bool require_rt = false;
  bool lock_memory = true;  ///< mlockall at start
  int priority = 80;        ///< SCHED_FIFO priority of the loop thread (1..99)
  int cpu = -1;             ///< CPU to pin the loop thread to; -1 = no pinning
  /// Cycle computation time above which the cycle counts as an overrun [ms]; 0 = half a period.
  double overrun_budget_ms = 0.0;
};

struct RecordConfig {
  bool enabled = false;  ///< record every published message to an LCM log
  /// Log file name; strftime patterns are expanded at start (e.g. %Y%m%d-%H%M%S).
  std::string path = "/var/lib/ftid/ftidd-%Y%m%d-%H%M%S.lcm";
};

/// A rigid part between the flange and the sensor's measuring side (the sensor cannot weigh it),
/// for the UR payload export (docs/operations.md "Exports").
struct RigidPartConfig {
  double mass = 0.0;          ///< [kg]
  Vec3 com_F = Vec3::Zero();  ///< centre of mass in the flange frame F [m]
  /// Inertia about its own centre of mass, axes of F, UR order [ixx, iyy, izz, ixy, ixz, iyz]
  /// [kg m^2].
  Vec6 inertia_C_F = Vec6::Zero();
};

/// The published output (compensated_wrench_t.output): frame and low-pass (docs/daemon.md).
struct OutputConfig {
  std::string frame = "sensor";        ///< sensor | tool | base
  Vec3 tool_xyz = Vec3::Zero();        ///< tool frame T origin in S [m] (p_ST_S)
  Vec3 tool_rpy = Vec3::Zero();        ///< R_ST = Rz(yaw) Ry(pitch) Rx(roll) [rad]
  double lowpass_hz = 0.0;             ///< 2nd-order Butterworth cut-off; 0 = off
  Mat3 R_ST() const;
};

/// The payload monitor (docs/daemon.md, "Payload monitor"; ftid/monitor/payload_monitor.hpp
/// explains each setting; defaults measured, docs/performance.md "Payload monitor").
struct MonitorConfig {
  bool enabled = true;
  std::string channel = "FTID_MONITOR";   ///< payload_monitor_t
  double publish_hz = 4.0;                ///< payload_monitor_t rate (and on every event)
  Vec6 noise_std = (Vec6() << 0.3, 0.3, 0.3, 0.03, 0.03, 0.03).finished();  ///< residual floor [N, Nm]
  double onset_margin = 6.0;
  double onset_threshold = 40.0;
  double decision_threshold = 12.0;       ///< [nats]
  double contact_force_std_N = 10.0;
  double contact_torque_std_Nm = 1.0;
  double contact_force_rate_N_s = 40.0;
  double contact_torque_rate_Nm_s = 4.0;
  double prior_mass_std_kg = 5.0;
  double prior_mass_com_std_kg_m = 0.5;
  double prior_inertia_std_kg_m2 = 0.02;
  double free_motion_turn_rad_s = 0.05;   ///< free motion: gravity turns in S at least this fast
  double free_motion_acc_m_s2 = 0.3;      ///< or the sensor accelerates at least this much
  double max_gap_s = 0.1;
  double restart_s = 1.0;
  double min_change_s = 0.1;              ///< a change is decided only after lasting this long [s]
  /// REIDENTIFY fits the change on the last this many seconds of valid cycles [s] (0.5..30).
  double reidentify_window_s = 4.0;
};

/// Names and parts used by the exports (`ftid export`, `identify --out`, `ftid --identify`).
struct ExportConfig {
  std::string world_frame = "base";       ///< ROS TF frame = robot base B (gravity_field is in it)
  std::string sensor_frame = "ft_sensor"; ///< ROS TF frame = sensor frame S
  std::string sensor_name = "ft_sensor";  ///< force_torque_sensor_broadcaster sensor_name
  RigidPartConfig adapter;                ///< adapter plate between flange and sensor
  RigidPartConfig sensor_body;            ///< the sensor's own body up to its measuring side
};

struct DaemonConfig {
  RobotConfig robot;
  SensorConfig sensor;
  ParametersConfig parameters;
  LcmConfig lcm;
  RtConfig rt;
  RecordConfig record;
  ExportConfig exports;  ///< YAML section `export`
  OutputConfig output;
  MonitorConfig monitor;
  std::string source;  ///< the file this was loaded from ("" for defaults)
  /// Legal but risky settings found by validation (e.g. lcm.url ttl > 1); ftidd and
  /// --check-config print them.
  std::vector<std::string> warnings;
};

/// Checks an LCM provider URL. udpm://ADDR:PORT?opts needs an IPv4 multicast ADDR
/// (224.0.0.0/4), PORT 1..65535 and options among ttl=0..255 and recv_buf_size=N; memq:// takes
/// nothing; file://PATH and tcpq://HOST:PORT are checked for shape. Throws ConfigError
/// "WHERE: key 'lcm.url': ..."; appends a warning if ttl > 1 (datagrams routed beyond one hop).
void checkLcmUrl(const std::string& url, const std::string& where, std::vector<std::string>* warnings);

/// Loads and validates a config file (a regular file, opened with O_NONBLOCK; duplicate keys are
/// errors). Keys not given keep their defaults. Throws ConfigError
/// "FILE:LINE: key 'section.name': problem" for unknown keys, duplicate keys, wrong types and bad
/// values, or "FILE: ..." if the file cannot be read or parsed.
DaemonConfig loadDaemonConfig(const std::string& path);

/// Same, from YAML text; source_name is used in messages and relative paths resolve against
/// base_dir.
DaemonConfig parseDaemonConfig(const std::string& yaml_text, const std::string& source_name,
                               const std::string& base_dir);

/// Checks cross-field consistency of a config built in code (the loaders call it). Throws
/// ConfigError naming the key.
void validateDaemonConfig(const DaemonConfig& config);

/// "" if this process may create files in the directory of `path`, else the reason. Not part of
/// validation (which runs as whoever loads ftidd.yaml): ftidd calls it at start, as its own user.
std::string recordDirWritableProblem(const std::string& path);

/// Human-readable dump of the effective configuration (for `ftidd --check-config`).
std::string describeDaemonConfig(const DaemonConfig& config);

}  // namespace ftid::config
