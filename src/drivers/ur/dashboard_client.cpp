#include "ftid/drivers/ur/dashboard_client.hpp"

#include <sys/socket.h>

#include <cerrno>
#include <cstring>

#include "ftid/common/error.hpp"
#include "socket_util.hpp"

namespace ftid::drivers::ur {

DashboardClient::~DashboardClient() { disconnect(); }

void DashboardClient::connect(const std::string& host, std::uint16_t port, std::chrono::milliseconds timeout) {
  disconnect();
  fd_ = detail::connectTcp(host, port, timeout, "dashboard");
  buffer_.clear();
  const std::string greeting = readLine();
  if (greeting.find("Connected") == std::string::npos) {
    disconnect();
    throw DriverError("dashboard " + host + ":" + std::to_string(port) + ": unexpected greeting '" + greeting + "'");
  }
}

void DashboardClient::disconnect() noexcept { detail::closeFd(&fd_); }

std::string DashboardClient::readLine() {
  const auto deadline = std::chrono::steady_clock::now() + timeout_;
  for (;;) {
    const auto nl = buffer_.find('\n');
    if (nl != std::string::npos) {
      std::string line = buffer_.substr(0, nl);
      buffer_.erase(0, nl + 1);
      if (!line.empty() && line.back() == '\r') line.pop_back();
      return line;
    }
    const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) throw DriverError("dashboard: no reply within 2.5 s");
    const int r = detail::waitReadable(fd_, left.count());
    if (r < 0) throw DriverError("dashboard: poll failed");
    if (r == 0) continue;
    char buf[512];
    const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
    if (n == 0) throw DriverError("dashboard: connection closed by the controller");
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) continue;
      throw DriverError(std::string("dashboard: recv failed: ") + std::strerror(errno));
    }
    buffer_.append(buf, static_cast<std::size_t>(n));
  }
}

std::string DashboardClient::command(const std::string& line) {
  if (fd_ < 0) throw DriverError("dashboard: not connected");
  const std::string msg = line + "\n";
  std::string err;
  if (!detail::sendAll(fd_, msg.data(), msg.size(), timeout_, &err)) {
    throw DriverError("dashboard: sending '" + line + "' failed: " + err);
  }
  return readLine();
}

namespace {
void expect(const std::string& cmd, const std::string& reply, const std::string& prefix) {
  if (reply.rfind(prefix, 0) != 0) {
    throw DriverError("dashboard: '" + cmd + "' answered '" + reply + "' (expected '" + prefix + "')");
  }
}
std::string afterColon(const std::string& reply) {
  const auto c = reply.find(':');
  std::string v = c == std::string::npos ? reply : reply.substr(c + 1);
  while (!v.empty() && v.front() == ' ') v.erase(0, 1);
  return v;
}
}  // namespace

void DashboardClient::powerOn() { expect("power on", command("power on"), "Powering on"); }
void DashboardClient::powerOff() { expect("power off", command("power off"), "Powering off"); }
void DashboardClient::brakeRelease() { expect("brake release", command("brake release"), "Brake releasing"); }
void DashboardClient::unlockProtectiveStop() {
  expect("unlock protective stop", command("unlock protective stop"), "Protective stop releasing");
}
void DashboardClient::play() { expect("play", command("play"), "Starting program"); }
void DashboardClient::stop() { expect("stop", command("stop"), "Stopped"); }
std::string DashboardClient::robotMode() {
  const std::string r = command("robotmode");
  expect("robotmode", r, "Robotmode:");
  return afterColon(r);
}
std::string DashboardClient::safetyMode() {
  const std::string r = command("safetymode");
  expect("safetymode", r, "Safetymode:");
  return afterColon(r);
}
std::string DashboardClient::programState() { return command("programState"); }
bool DashboardClient::isProgramRunning() {
  const std::string r = command("running");
  expect("running", r, "Program running:");
  return afterColon(r) == "true";
}
std::string DashboardClient::polyscopeVersion() { return command("PolyscopeVersion"); }

}  // namespace ftid::drivers::ur
