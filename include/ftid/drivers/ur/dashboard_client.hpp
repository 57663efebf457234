#pragma once
// UR dashboard server client (TCP 29999, '\n'-terminated lines). Non-real-time; every call has a
// timeout and throws DriverError with the command and the reply on failure.
#include <chrono>
#include <cstdint>
#include <string>

namespace ftid::drivers::ur {

inline constexpr std::uint16_t kDashboardPort = 29999;

class DashboardClient {
 public:
  DashboardClient() = default;
  ~DashboardClient();
  DashboardClient(const DashboardClient&) = delete;
  DashboardClient& operator=(const DashboardClient&) = delete;

  /// Connects and reads the greeting ("Connected: Universal Robots Dashboard Server").
  void connect(const std::string& host, std::uint16_t port = kDashboardPort,
               std::chrono::milliseconds timeout = std::chrono::milliseconds(2000));
  void disconnect() noexcept;
  bool isConnected() const noexcept { return fd_ >= 0; }

  /// Sends one command line and returns the reply line (without the newline).
  std::string command(const std::string& line);

  // Convenience wrappers. Each checks the reply text and throws DriverError if unexpected.
  void powerOn();              ///< "Powering on"
  void powerOff();             ///< "Powering off"
  void brakeRelease();         ///< "Brake releasing"
  void unlockProtectiveStop(); ///< "Protective stop releasing"
  void play();                 ///< "Starting program"
  void stop();                 ///< "Stopped"
  std::string robotMode();     ///< e.g. "RUNNING" (from "Robotmode: RUNNING")
  std::string safetyMode();    ///< e.g. "NORMAL" (from "Safetymode: NORMAL")
  std::string programState();  ///< e.g. "PLAYING ftid_servo" or "STOPPED <name>"
  bool isProgramRunning();     ///< "Program running: true"
  std::string polyscopeVersion();

 private:
  std::string readLine();
  int fd_ = -1;
  std::string buffer_;
  std::chrono::milliseconds timeout_{2500};
};

}  // namespace ftid::drivers::ur
