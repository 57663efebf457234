#include "dashboard_server.hpp"

#include <unistd.h>

#include <exception>
#include <sstream>

namespace ftid::simrobot {

namespace rtde = ftid::drivers::ur::rtde;

namespace {

constexpr const char* kGreeting = "Connected: Universal Robots Dashboard Server\n";

std::string programStateText(const Controller& k) {
  const std::string name = k.programName().empty() ? "<unnamed>" : k.programName() + ".urp";
  switch (k.runtimeState()) {
    case rtde::kRuntimePlaying: return "PLAYING " + name;
    case rtde::kRuntimePaused: return "PAUSED " + name;
    default: return "STOPPED " + name;
  }
}

}  // namespace

std::string DashboardServer::execute(Controller& k, const std::string& raw, bool* close) {
  std::string cmd = raw;
  while (!cmd.empty() && (cmd.back() == '\r' || cmd.back() == ' ')) cmd.pop_back();
  while (!cmd.empty() && cmd.front() == ' ') cmd.erase(0, 1);
  if (cmd == "stop") {
    k.stopProgram("dashboard stop");
    return "Stopped";
  }
  if (cmd == "play") return k.play() ? "Starting program" : "Failed to execute: play";
  if (cmd == "pause") {
    k.pause();
    return "Pausing program";
  }
  if (cmd == "PolyscopeVersion") {
    return std::string("URSoftware ") + k.version().toString() +
           (k.version().major >= 5 ? " (Mar 22 2021)" : " (Nov 29 2021)");
  }
  if (cmd == "get serial number") return k.config().serial_number;
  if (cmd == "is in remote control") return "true";
  if (cmd == "robotmode") return std::string("Robotmode: ") + rtde::robotModeName(k.robotMode());
  if (cmd == "safetymode") return std::string("Safetymode: ") + rtde::safetyModeName(k.safetyMode());
  if (cmd == "safetystatus") return std::string("Safetystatus: ") + rtde::safetyModeName(k.safetyMode());
  if (cmd == "programState") return programStateText(k);
  if (cmd == "running") {
    return std::string("Program running: ") + (k.runtimeState() == rtde::kRuntimePlaying ? "true" : "false");
  }
  if (cmd == "get loaded program") {
    return k.programName().empty() ? "No program loaded" : "Loaded program: " + k.programName() + ".urp";
  }
  if (cmd == "power on") {
    k.powerOn();
    return "Powering on";
  }
  if (cmd == "power off") {
    k.powerOff();
    return "Powering off";
  }
  if (cmd == "brake release") {
    k.brakeRelease();
    return "Brake releasing";
  }
  if (cmd == "unlock protective stop") {
    k.unlockProtectiveStop();
    return "Protective stop releasing";
  }
  if (cmd == "close safety popup") return "closing safety popup";
  if (cmd == "close popup") return "closing popup";
  if (cmd.rfind("load ", 0) == 0) return "Loading program: " + cmd.substr(5);
  if (cmd == "quit") {
    *close = true;
    return "Disconnected";
  }
  if (cmd.rfind("sim ", 0) == 0) {  // simulator extension: fault injection
    std::istringstream is(cmd.substr(4));
    std::string kind;
    int count = 10;
    is >> kind >> count;
    try {
      k.inject(parseFaultKind(kind), count);
      return "Sim: injected " + kind;
    } catch (const std::exception& e) {
      return std::string("Sim: ") + e.what();
    }
  }
  return "could not understand: '" + cmd + "'";
}

DashboardServer::DashboardServer(Controller& controller, int listen_fd)
    : controller_(controller), listen_fd_(listen_fd) {}

DashboardServer::~DashboardServer() { closeAll(); }

std::size_t DashboardServer::addPollFds(std::vector<pollfd>* fds) const {
  fds->push_back({listen_fd_, POLLIN, 0});
  for (const auto& c : conns_) {
    fds->push_back({c->fd, static_cast<short>(POLLIN | (c->tx.empty() ? 0 : POLLOUT)), 0});
  }
  return conns_.size() + 1;
}

void DashboardServer::onPoll(const pollfd* fds, std::size_t n) {
  if (n == 0) return;
  const std::size_t existing = conns_.size();
  if (fds[0].revents & POLLIN) {
    const int fd = net::acceptConnection(listen_fd_);
    if (fd >= 0) {
      auto c = std::make_unique<net::LineConnection>();
      c->fd = fd;
      c->tx = kGreeting;
      c->flush();
      conns_.push_back(std::move(c));
    }
  }
  for (std::size_t i = 0; i < existing && i + 1 < n; ++i) {
    const pollfd& p = fds[i + 1];
    net::LineConnection* c = conns_[i].get();
    if (p.fd != c->fd) continue;
    if (p.revents & (POLLIN | POLLHUP | POLLERR)) read(c);
    if (p.revents & POLLOUT) c->flush();
  }
}

void DashboardServer::read(net::LineConnection* c) {
  if (!net::readAvailable(c->fd, &c->rx)) c->close = true;
  std::size_t nl;
  while ((nl = c->rx.find('\n')) != std::string::npos) {
    const std::string line = c->rx.substr(0, nl);
    c->rx.erase(0, nl + 1);
    bool close = false;
    c->tx += execute(controller_, line, &close) + "\n";
    c->flush();
    if (close) {
      c->close = true;
      break;
    }
  }
  c->flush();
}

void DashboardServer::closeMarked() { net::closeMarked(&conns_); }

void DashboardServer::disconnectAll() {
  for (auto& c : conns_) c->close = true;
}

void DashboardServer::closeAll() { net::closeAll(&conns_, &listen_fd_); }

}  // namespace ftid::simrobot
