#pragma once
// The simulator's dashboard server (port 29999; docs/robot.md "Dashboard"): UR's reply texts for
// the subset ftid and ur_rtde use, plus the `sim ...` fault-injection extension. One command per
// line; it changes the controller only through Controller's program-control calls.
#include <poll.h>

#include <memory>
#include <string>
#include <vector>

#include "ftid/simrobot/controller.hpp"
#include "net.hpp"

namespace ftid::simrobot {

class DashboardServer {
 public:
  DashboardServer(Controller& controller, int listen_fd);  ///< owns listen_fd
  ~DashboardServer();
  DashboardServer(const DashboardServer&) = delete;
  DashboardServer& operator=(const DashboardServer&) = delete;

  /// The reply to one command line (without its newline); *close is set by `quit`.
  static std::string execute(Controller& controller, const std::string& line, bool* close);

  std::size_t addPollFds(std::vector<pollfd>* fds) const;
  void onPoll(const pollfd* fds, std::size_t n);
  void closeMarked();
  void disconnectAll();
  void closeAll();

 private:
  void read(net::LineConnection* c);

  Controller& controller_;
  int listen_fd_;
  std::vector<std::unique_ptr<net::LineConnection>> conns_;
};

}  // namespace ftid::simrobot
